"""Fuzzing every method of the default registry around its example (issue 22).

In process, each drawn params object is validated by its model, checked,
run and encoded: it must come back, or fail with the model's validation
error or a :class:`~meshcore.errors.MeshcoreError`, and nothing else. A
smaller sample goes through the live server: every answer is 2xx or 4xx and
no job fails with a 5xx problem. See :mod:`tests.service.fuzzing` for the
mutations and the profiles (``MESHSERVICE_FUZZ=long`` for a long run).
"""

from __future__ import annotations

import json

import pytest
from hypothesis import given, note, settings
from pydantic import ValidationError

from meshcore.errors import MeshcoreError
from service.methods.registry import default_registry
from service.runner import encode_result
from tests.service.fuzzing import PROFILE, mutated

pytestmark = pytest.mark.kernels  # every method runs in this process

REGISTRY = default_registry()
METHODS = sorted(REGISTRY)
#: Methods whose extreme examples are legitimately slow get a third of the examples in the
#: ci profile: medial_transform with a tiny h builds 16384-gon disks and 2e6 Hausdorff
#: samples (its documented caps), about 35 s per example.
COSTLY = {"medial_transform": 3}


def outcome(spec, params: dict) -> str:
    """``refused`` (schema), ``invalid`` (check or run: MeshcoreError) or ``ran``."""
    try:
        model = spec.params.model_validate(params)
    except ValidationError:
        return "refused"
    try:
        model.check()
        encode_result(spec.run(model, lambda f, m: None))
    except MeshcoreError:
        return "invalid"
    return "ran"


@pytest.mark.parametrize("method", METHODS)
def test_method_returns_or_raises_meshcore_error(method):
    spec = REGISTRY[method]

    examples = PROFILE.max_examples
    if PROFILE is settings.get_profile("ci"):
        examples = max(2, examples // COSTLY.get(method, 1))

    @settings(PROFILE, max_examples=examples)
    @given(mutated(spec))
    def fuzz(params):
        note(json.dumps(params))
        outcome(spec, params)

    fuzz()


@pytest.mark.parametrize("method", METHODS)
def test_live_server_answers_2xx_or_4xx_and_no_job_fails_with_5xx(method, live):
    spec = REGISTRY[method]
    with live.client() as c:

        @settings(PROFILE, max_examples=max(2, PROFILE.max_examples // 4))
        @given(mutated(spec))
        def fuzz(params):
            note(json.dumps(params))
            r = c.post("/v1/jobs", json={"method": method, "params": params}, params={"wait": 30})
            assert r.status_code < 500, (r.status_code, r.text[:500], json.dumps(params)[:500])
            job = r.json()
            if r.status_code in (200, 202) and job["status"] == "failed":
                assert job["error"]["status"] < 500, (job["error"], json.dumps(params)[:500])
            if r.status_code == 200 and job["status"] == "succeeded":
                c.delete(f"/v1/jobs/{job['id']}")

        fuzz()
