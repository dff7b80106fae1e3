"""Big bodies: coordinates parsed from the bytes, refusals unchanged, inputs validated once.

In-process (no server): the submit's parse (:func:`service.bodies.extract_coordinates`
then the request model) against the ordinary parse of the same bytes, and the
job's params (``domain_schema.pack`` / ``unpack``) against the submit's.
"""

from __future__ import annotations

import io
import json

import numpy as np
import pytest
from pydantic import TypeAdapter, ValidationError

from service import bodies
from service.api.jobs import request_model
from service.methods.domain_schema import ARRAYS, PACK, pack_arrays, unpack, write_npz
from service.methods.registry import default_registry
from service.methods.surface_schema import UNIT_CUBE
from service.runner import run_job

pytestmark = pytest.mark.kernels  # the domain checks run in this process

REGISTRY = default_registry()
ADAPTER = TypeAdapter(request_model(REGISTRY))


def _ring(n: int, r: float = 1.0, cx: float = 0.0, reverse: bool = False) -> list:
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    if reverse:
        t = -t
    return np.column_stack([cx + r * np.cos(t), r * np.sin(t)]).tolist()


def _body(domain: dict, **params) -> bytes:
    return json.dumps({"method": "triangulate", "params": {"domain": domain, **params}}).encode()


def _submit_parse(raw: bytes):
    body, arrays = bodies.extract_coordinates(raw)
    return ADAPTER.validate_json(body, context={ARRAYS: arrays} if arrays else None), arrays


def _errors(raw: bytes) -> list:
    with pytest.raises(ValidationError) as err:
        _submit_parse(raw)
    return [(e["loc"], e["type"]) for e in err.value.errors()]


POLYGON = {"type": "Polygon", "coordinates": [_ring(5000), _ring(300, 0.3, reverse=True)]}
MULTI = {
    "type": "MultiPolygon",
    "coordinates": [[_ring(4000)], [_ring(3000, 1.0, 5.0), _ring(100, 0.2, 5.0, reverse=True)]],
}


@pytest.mark.parametrize("domain", [POLYGON, MULTI], ids=["Polygon", "MultiPolygon"])
def test_big_coordinates_come_from_the_bytes_equal_to_the_ordinary_parse(domain):
    raw = _body(domain, segments=[[[-0.5, 0.5], [0.5, 0.5]]])
    fast, arrays = _submit_parse(raw)
    assert len(arrays) == 1 and len(raw) >= bodies.MIN_BODY  # the fast path was taken
    slow = ADAPTER.validate_json(raw)
    assert fast.params.domain.geometry() == slow.params.domain.geometry()
    assert fast.params.domain.geometry()["coordinates"] == domain["coordinates"]
    assert fast.params.domain.to_domain(fast.params.segments) == slow.params.domain.to_domain(
        slow.params.segments
    )


def test_hard_numbers_parse_as_float_does():
    # 17-digit mantissas, exponents beyond 1e22, subnormals: numpy's parser, not the fast path
    values = [0.1 + 0.2, 1e-310, 123456789.12345679, 1e23, -0.0, 2.5e-7, 7.0]
    ring = [[v, w] for v, w in zip(values, values[1:] + values[:1], strict=True)] * 2000
    raw = _body({"type": "Polygon", "coordinates": [ring]})
    fast, arrays = _submit_parse(raw)
    assert arrays
    got = np.asarray(fast.params.domain.coordinates[0])
    assert got.tobytes() == np.array(ring).tobytes()


@pytest.mark.parametrize(
    ("fault", "where"),
    [
        ([0.5, 0.5, 1.0], ("body", "triangulate", "params", "domain", "coordinates", 0, 7)),
        ([0.5, "x"], ("body", "triangulate", "params", "domain", "coordinates", 0, 7, 1)),
        ([0.5, True], ("body", "triangulate", "params", "domain", "coordinates", 0, 7, 1)),
        ([0.5], ("body", "triangulate", "params", "domain", "coordinates", 0, 7)),
    ],
)
def test_a_malformed_position_in_a_big_body_is_refused_where_it_is(fault, where):
    ring = _ring(5000)
    ring[7] = fault
    raw = _body({"type": "Polygon", "coordinates": [ring]})
    assert bodies.extract_coordinates(raw)[1] == {}  # left to pydantic
    loc = [tuple(e[0]) for e in _errors(raw)]
    assert tuple(where[1:]) in loc or where in loc


def test_infinite_and_wrong_depth_values_are_refused_as_by_the_ordinary_parse():
    ring = _ring(5000)
    ring[3] = [0.123, 0.456]
    text = _body({"type": "Polygon", "coordinates": [ring]}).replace(
        b"[0.123, 0.456]", b"[1e999, 0.456]", 1
    )
    assert bodies.extract_coordinates(text)[1] == {}  # scanned, then left: not finite
    with pytest.raises(ValidationError) as slow:
        ADAPTER.validate_json(text)
    assert _errors(text) == [(e["loc"], e["type"]) for e in slow.value.errors()]
    # a MultiPolygon's depth under "Polygon": the same refusal as the ordinary parse
    raw = _body({"type": "Polygon", "coordinates": MULTI["coordinates"]})
    with pytest.raises(ValidationError) as slow:
        ADAPTER.validate_json(raw)
    assert _errors(raw) == [(e["loc"], e["type"]) for e in slow.value.errors()]


def test_invalid_json_is_reported_at_its_place_in_the_body_sent():
    raw = _body(POLYGON)[:-1]
    with pytest.raises(ValidationError) as slow:
        ADAPTER.validate_json(raw)
    assert _errors(raw) == [(e["loc"], e["type"]) for e in slow.value.errors()]


def test_a_key_inside_a_string_is_not_taken():
    ring = _ring(5000)
    raw = json.dumps(
        {"method": "triangulate", "params": {"domain": {"type": "Polygon", "coordinates": [ring]}}}
    ).encode()
    decoy = b'"name": "\\"coordinates\\": [[[0, 0]]]", '
    raw = raw.replace(b'"params": {', b'"params": {' + decoy, 1)
    body, arrays = bodies.extract_coordinates(raw)
    assert len(arrays) == 1 and decoy in body


def test_the_job_uses_the_domain_the_submit_validated(monkeypatch):
    fast, _ = _submit_parse(_body(POLYGON, size=0.5))
    params = fast.params
    params.check()  # the submit's checks build the Domain once
    packed: dict = {}
    params_json = params.model_dump_json(context={PACK: packed}).encode()
    assert len(params_json) < 1000  # the rings travel as arrays, not JSON
    out = io.BytesIO()
    write_npz(pack_arrays(packed), out)  # as the submit writes params.npz
    arrays = out.getvalue()
    expected = params.domain.to_domain(params.segments)

    def refuse(*args, **kwargs):
        raise AssertionError("the job validated the domain again")

    monkeypatch.setattr("service.methods.domain_schema.parse_domain", refuse)
    again = REGISTRY["triangulate"].params.model_validate_json(params_json, context=unpack(arrays))
    assert again.domain.to_domain(again.segments) == expected
    assert again.domain.geometry() == params.domain.geometry()
    files = run_job(REGISTRY["triangulate"], params_json, lambda f, m: None, (), arrays)
    assert json.loads(files["json"])["mesh"]["points"]


def test_the_job_uses_the_surface_the_submit_validated(monkeypatch):
    body = {"method": "tetrahedralize", "params": {"surface": UNIT_CUBE, "size": 0.5}}
    params = ADAPTER.validate_json(json.dumps(body)).params
    params.check()  # the submit's checks build the Surface once
    packed: dict = {}
    params_json = params.model_dump_json(context={PACK: packed}).encode()
    assert b"[0.0,0.0,0.0]" not in params_json  # the points travel as arrays, not JSON
    out = io.BytesIO()
    write_npz(pack_arrays(packed), out)
    arrays = out.getvalue()
    expected = params.surface.to_surface()

    def refuse(*args, **kwargs):
        raise AssertionError("the job validated the surface again")

    monkeypatch.setattr("service.methods.surface_schema.parse_surface", refuse)
    again = REGISTRY["tetrahedralize"].params.model_validate_json(
        params_json, context=unpack(arrays)
    )
    surface = again.surface.to_surface()
    for name in ("points", "triangles", "triangle_reversed", "triangle_shell", "shell_region"):
        assert np.array_equal(getattr(surface, name), getattr(expected, name))
    assert (surface.volume, surface.diameter) == (expected.volume, expected.diameter)
    assert again.model_dump() == params.model_dump()  # plain lists again when dumped
    files = run_job(REGISTRY["tetrahedralize"], params_json, lambda f, m: None, (), arrays)
    assert json.loads(files["json"])["stats"]["volume"] == pytest.approx(1.0)
