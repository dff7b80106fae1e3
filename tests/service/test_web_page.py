"""The web page at ``/`` in a real browser (Debian's Chromium through Playwright).

End to end against a live uvicorn: draw a square with a hole by clicks, run
``triangulate``, watch the progress, see the mesh drawn, the histogram, download
VTU and read it back; a bow-tie's 422 highlighted on the drawing; an upload
through ``/v1/convert`` extruded and shown in 3D; a long job cancelled; API keys.
Screenshots of each step go to ``test-artifacts/``. Skipped (one line) when
Playwright or Chromium is missing; CI installs Chromium in ``.ci/run``.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import meshio
import numpy as np
import pytest

from tests.service.conftest import ROOT, LiveServer

pytestmark = pytest.mark.kernels  # the page triangulates on its server

CHROMIUM = os.environ.get("MESHSERVICE_CHROMIUM") or shutil.which("chromium") or "/usr/bin/chromium"
ARGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--use-angle=swiftshader",
    "--enable-unsafe-swiftshader",
]
ARTIFACTS = ROOT / "test-artifacts"
KEYS = "good-key:alice"
BACKGROUND = np.array([244, 246, 249])  # viewer.js BACKGROUND

sync_api = pytest.importorskip("playwright.sync_api", reason="playwright is not installed")
if not Path(CHROMIUM).exists():
    pytest.skip(f"no Chromium at {CHROMIUM} (apt-get install chromium)", allow_module_level=True)


@pytest.fixture(scope="module")
def browser():
    with sync_api.sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, args=ARGS)
        yield b
        b.close()


@pytest.fixture(scope="module")
def keyed(tmp_path_factory):
    """One server with API keys for every test here (keys are what a deployment has)."""
    server = LiveServer(tmp_path_factory.mktemp("web") / "data", MESHSERVICE_API_KEYS=KEYS)
    server.start()
    yield server
    server.stop()


def _page(browser, key: str | None):
    """A fresh page (with ``key`` in sessionStorage) and the list of its errors.

    Chromium logs every non-2xx fetch as "Failed to load resource"; the tests
    provoke 401s and 422s on purpose, so those lines are not errors of the page.
    """
    context = browser.new_context(viewport={"width": 1400, "height": 1000}, accept_downloads=True)
    if key:
        context.add_init_script(f"sessionStorage.setItem('meshservice.apiKey', '{key}')")
    pg = context.new_page()
    errors: list[str] = []
    pg.on("pageerror", lambda e: errors.append(f"pageerror: {e}"))
    pg.on(
        "console",
        lambda m: (
            errors.append(m.text)
            if m.type == "error" and "Failed to load resource" not in m.text
            else None
        ),
    )
    pg.set_default_timeout(30000)
    return context, pg, errors


@pytest.fixture
def page(browser):
    """A page holding the good API key; fails the test on any script or console error."""
    context, pg, errors = _page(browser, "good-key")
    yield pg
    context.close()
    assert errors == []


@pytest.fixture
def bare_page(browser):
    """A page without an API key."""
    context, pg, errors = _page(browser, None)
    yield pg
    context.close()
    assert errors == []


def shot(page, name: str, selector: str | None = None, full: bool = True) -> Path:
    """A screenshot of an element, of the whole page, or (``full=False``) of the window."""
    ARTIFACTS.mkdir(exist_ok=True)
    path = ARTIFACTS / f"web-{name}.png"
    if selector:
        page.locator(selector).screenshot(path=path)
    else:
        page.screenshot(path=path, full_page=full)
    return path


def drawn_fraction(path: Path) -> float:
    from PIL import Image

    pixels = np.asarray(Image.open(path).convert("RGB"), dtype=int)
    return float(np.mean(np.abs(pixels - BACKGROUND).sum(axis=2) > 24))


def open_page(page, url: str) -> None:
    page.goto(url + "/")
    page.wait_for_function("document.querySelectorAll('#method option').length > 0")


def click_at(page, x: float, y: float) -> None:
    box = page.locator("#domain-canvas").bounding_box()
    sx, sy = page.evaluate("([x, y]) => meshPage.editor.toScreen(x, y)", [x, y])
    page.mouse.click(box["x"] + sx, box["y"] + sy)


def draw_rings(page, rings) -> None:
    """Draw rings by clicks: the first closed by clicking its first point, the others by Enter."""
    page.click("#clear")
    for i, ring in enumerate(rings):
        for x, y in ring:
            click_at(page, x, y)
        if i == 0:
            click_at(page, *ring[0])
        else:
            page.locator("#domain-canvas").press("Enter")


def choose(page, method: str) -> None:
    page.select_option("#method", method)
    page.wait_for_function(
        f"meshPage.state.form && document.getElementById('method').value === '{method}'"
    )


def wait_drawn(page) -> None:
    page.wait_for_function("document.getElementById('result-status').textContent.includes('drawn')")


SQUARE = [(0, 0), (1, 0), (1, 1), (0, 1)]
HOLE = [(0.3, 0.3), (0.7, 0.3), (0.7, 0.7), (0.3, 0.7)]


def test_triangulate_a_drawn_square_with_a_hole(keyed, page, tmp_path):
    open_page(page, keyed.url)
    draw_rings(page, [SQUARE, HOLE[:3]])  # a three-point hole first ...
    page.click("#undo")  # ... undone: the hole is open again
    click_at(page, *HOLE[3])
    page.locator("#domain-canvas").press("Enter")
    geometry = page.evaluate("meshPage.editor.geometry()")
    assert geometry["type"] == "Polygon"
    assert [len(r) for r in geometry["coordinates"]] == [5, 5]
    assert geometry["coordinates"][1][:4] == [list(p) for p in HOLE]
    shot(page, "1-drawn", "#domain")
    choose(page, "triangulate")
    page.get_by_label("use curves").uncheck()  # the example's circle is not our square hole
    page.get_by_label("min_angle", exact=True).fill("30")
    page.click("#submit")
    wait_drawn(page)
    assert page.eval_on_selector("#progress", "e => e.value") == 1
    assert page.text_content("#progress-message") == "done"
    fraction = drawn_fraction(shot(page, "2-mesh", ".view-box"))
    assert fraction > 0.2  # the mesh covers the view, not the background
    page.click("#histogram-box summary")
    assert page.locator("svg.histogram").first.is_visible()
    assert "triangle" in page.text_content("#quality-table")
    shot(page, "3-result", "#result")
    with page.expect_download() as info:
        page.get_by_role("button", name="Download the mesh as vtu").click()
    target = tmp_path / "mesh.vtu"
    info.value.save_as(target)
    mesh = meshio.read(target)
    tri = mesh.points[mesh.cells_dict["triangle"]]
    area = 0.5 * np.abs(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])[:, 2])
    assert area.sum() == pytest.approx(1 - 0.4 * 0.4)
    shot(page, "4-page")
    page.evaluate("window.scrollTo(0, 0)")
    shot(page, "4-window", full=False)  # docs/web-page.png
    page.set_viewport_size({"width": 700, "height": 1000})  # 200 % zoom of a 1400 px window
    page.wait_for_timeout(100)
    assert page.evaluate("document.documentElement.scrollWidth <= window.innerWidth")
    shot(page, "5-zoom-200")


def test_a_bow_tie_shows_the_422_and_highlights_the_crossing(keyed, page):
    open_page(page, keyed.url)
    draw_rings(page, [[(0, 0), (1, 1), (1, 0), (0, 1)]])
    choose(page, "triangulate")
    page.get_by_label("use curves").uncheck()
    page.get_by_label("min_angle", exact=True).fill("40")  # the schema's maximum is 34
    page.click("#submit")
    assert "Fix 1 field" in page.text_content("#run-status")  # checked in the page, not sent
    assert "at most 34" in page.locator(".field.invalid .field-error").first.text_content()
    page.get_by_label("min_angle", exact=True).fill("30")
    page.click("#submit")
    page.wait_for_function("document.getElementById('run-status').textContent.includes('Refused')")
    assert "intersects itself" in page.text_content("#run-status")
    assert "intersects itself" in page.locator(".field.invalid .field-error").first.text_content()
    marks = page.evaluate("meshPage.editor.marks")
    assert marks["segments"] == [[0, 0, 0, 1], [0, 0, 2, 3]]
    shot(page, "6-bow-tie", "#domain")
    page.select_option("#example", "gear")  # an example replaces the drawing
    assert len(page.evaluate("meshPage.editor.geometry()")["coordinates"]) == 2
    page.click("#domain summary")  # pasted GeoJSON does too
    page.fill("#geojson", '{"type": "Polygon", "coordinates": [[[0, 0], [2, 0], [0, 2]]]}')
    page.click("#use-geojson")
    assert page.evaluate("meshPage.editor.geometry()")["coordinates"] == [
        [[0, 0], [2, 0], [0, 2], [0, 0]]
    ]


def test_an_uploaded_mesh_extruded_shows_a_3d_view(keyed, page, tmp_path):
    open_page(page, keyed.url)
    square = meshio.Mesh(
        np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [2, 0, 0], [2, 1, 0]], float),
        [("quad", np.array([[0, 1, 2, 3], [1, 4, 5, 2]]))],
    )
    square.write(tmp_path / "base.vtu")
    page.set_input_files("#mesh-file", str(tmp_path / "base.vtu"))
    page.wait_for_function(
        "document.getElementById('mesh-status').textContent.includes('Uploaded')"
    )
    assert "2 quad" in page.text_content("#mesh-status")
    choose(page, "extrude")
    page.click("#submit")
    wait_drawn(page)
    assert page.text_content("#view-kind").startswith("3D view")
    assert page.evaluate("meshPage.viewer.layer('cells').count") == 3 * 2 * (2 * 2 + 2 * 3 * 10)
    page.locator("#view").press("ArrowLeft")  # orbit by keyboard
    page.wait_for_timeout(100)
    assert drawn_fraction(shot(page, "7-extrude-3d", ".view-box")) > 0.05
    page.check("#clip")
    page.wait_for_timeout(100)
    assert drawn_fraction(shot(page, "8-extrude-clipped", ".view-box")) > 0.05


def test_cancel_a_long_job(keyed, page):
    open_page(page, keyed.url)
    choose(page, "sleep")
    page.get_by_label("seconds", exact=True).fill("60")
    page.click("#submit")
    page.wait_for_function("document.getElementById('run-status').textContent.includes('running')")
    page.click("#cancel")
    page.wait_for_function(
        "document.getElementById('run-status').textContent.includes('cancelled')"
    )
    page.wait_for_function(  # the job list shows it too
        "document.querySelector('#jobs-body tr').textContent.includes('cancelled')"
    )
    shot(page, "9-cancelled", "#run")


def test_api_keys(keyed, bare_page):
    page = bare_page
    page.goto(keyed.url + "/")
    page.wait_for_function("!document.getElementById('notice').hidden")
    assert "needs an API key" in page.text_content("#notice")
    page.fill("#api-key", "wrong-key")
    page.click("#settings-form button")
    page.wait_for_function("document.getElementById('notice').textContent.includes('not valid')")
    assert "refused the API key" in page.text_content("#notice")
    shot(page, "10-wrong-key")
    page.fill("#api-key", "good-key")
    page.click("#settings-form button")
    page.wait_for_function(  # the job list loaded with the key
        "['Page 1', 'No jobs yet.'].includes(document.getElementById('jobs-status').textContent)"
    )
    assert page.is_hidden("#notice")
    assert page.evaluate("sessionStorage.getItem('meshservice.apiKey')") == "good-key"
