"""The studio's views as a designer meets them (issue 33, item 4, the views half), in a real
browser: the scope's and the spectrogram's axes (session time, Hz, dB, negative labels whole),
the wiring graph's text size, the stage's legend and markers, the 3-D camera, and a waveguide
patch drawn on the stage. `hapticgraph studio` on loopback, Debian's chromium through Selenium."""
import time

import pytest

from browser_env import patch_page, send, until


def tab(driver, name):
    driver.find_element("css selector", f"#tabs button[data-tab={name}]").click()


def session_t(driver):
    return until(lambda: driver.execute_script("return window.studio.status && window.studio.status.t"), 10,
                 "no status event")


def test_the_scope_counts_in_session_time(tmp_path):
    with patch_page(tmp_path, "cymatic_sheet", "scope_time") as driver:
        until(lambda: session_t(driver) > 2.0, 30, "the session's t did not pass 2 s")
        tab(driver, "scope")
        until(lambda: driver.execute_script("return window.studio.scopes.len > 4410"), 30, "no probe data")
        time.sleep(0.3)
        t, shown = driver.execute_script(
            "const u = window.studio.scopes.plot; return [window.studio.status.t, [u.data[0][0], u.data[0].at(-1)]]")
    # the scope's last sample is the session's now (the status event comes twice a second or so),
    # not the seconds since the probe started (which would be under 1 s here)
    assert shown[1] > 2.0, shown
    assert abs(shown[1] - t) < 1.0, (shown, t)
    assert shown[0] < shown[1]


def _ink_at_left(driver, selector):
    """Columns 0-1 of a canvas: how many pixels are drawn (not the background)."""
    return driver.execute_script(
        "const c = document.querySelector(arguments[0]), g = c.getContext('2d');"
        "const d = g.getImageData(0, 0, 2, c.height).data; let ink = 0;"
        "for (let i = 0; i < d.length; i += 4) if (d[i] + d[i + 1] + d[i + 2] > 200) ink++;"
        "return ink;", selector)


def test_negative_axis_labels_keep_their_minus_sign(tmp_path):
    with patch_page(tmp_path, "cymatic_sheet", "scope_minus") as driver:
        tab(driver, "scope")
        until(lambda: driver.execute_script("return window.studio.scopes.len > 4410"), 30, "no probe data")
        labels = until(lambda: driver.execute_script(
            "const l = window.studio.scopes.labels.y; return l.some(s => /^[-−]/.test(s)) && l"), 30,
            "no negative label on the scope's value axis")
        ink = _ink_at_left(driver, "#scope canvas")
    # a label drawn whole leaves the plot's left edge empty; a clipped one ("−1.000e-5" in an axis
    # too narrow for it) starts left of the canvas and its ink touches column 0
    assert ink == 0, (labels, ink)


def test_the_spectrogram_fills_its_panel_with_axes_in_hz_s_and_db(tmp_path):
    with patch_page(tmp_path, "cymatic_sheet", "spectrogram") as driver:
        tab(driver, "scope")
        axes = until(lambda: driver.execute_script(
            "const a = window.studio.scopes.spectrogram.axes; return a && a.columns >= 20 && a"), 30,
            "no spectrogram columns")
        t = session_t(driver)
        sizes = driver.execute_script(
            "const c = document.querySelector('#spectrogram'), p = document.querySelector('#tab-scope');"
            "return [c.width, c.height, p.clientWidth];")
        # the picture's first and last pixel columns (the plot's left and right edge, half-way up)
        edges = driver.execute_script(
            "const a = arguments[0].plot, g = document.querySelector('#spectrogram').getContext('2d');"
            "const at = (x) => Array.from(g.getImageData(x, Math.round(a.y + a.h / 2), 1, 1).data.slice(0, 3));"
            "return [at(a.x + 1), at(a.x + a.w - 2)];", axes)
    width, height, panel = sizes
    assert width >= panel - 20 and height >= 200, sizes                   # the whole panel, not 520 px
    plot = axes["plot"]
    assert plot["w"] >= 0.75 * width and plot["h"] >= 0.6 * height, (plot, sizes)
    background = [0x10, 0x13, 0x17]
    assert edges[0] != background and edges[1] != background, edges      # filled from edge to edge
    assert {"100", "1k"} <= set(axes["freq"]), axes["freq"]              # log frequency, in Hz
    times = [float(s.replace("−", "-")) for s in axes["time"]]
    assert len(times) >= 2 and abs(max(axes["t"]) - t) < 1.5, (axes["t"], t)   # the session's time
    assert all(axes["t"][0] <= v <= axes["t"][1] for v in times), (times, axes["t"])
    db = [float(s.replace("−", "-")) for s in axes["db"]]
    assert len(db) == 8 and db[0] - db[-1] == 70 and db == sorted(db, reverse=True), db   # the colour scale


def test_the_wiring_graph_is_readable(tmp_path):
    with patch_page(tmp_path, "fig8_pluck_damp", "wiring") as driver:
        tab(driver, "wiring")
        sizes = until(lambda: driver.execute_script(
            "return [...document.querySelectorAll('#wiring text')].map(t =>"
            " [t.textContent, parseFloat(getComputedStyle(t).fontSize) * t.getScreenCTM().a,"
            "  t.getBoundingClientRect().height, t.getComputedTextLength() * t.getScreenCTM().a,"
            "  t.parentNode.querySelector('rect').getBoundingClientRect().width])"), 10, "no wiring drawn")
    assert len(sizes) == 17, sizes                                 # fig8's blocks, one box each
    # the text as drawn on the screen (its font size times the SVG's scale), not as declared
    assert min(s[1] for s in sizes) >= 11, sizes
    assert min(s[2] for s in sizes) >= 11, sizes
    assert all(s[3] <= s[4] for s in sizes), [s for s in sizes if s[3] > s[4]]   # each name fits its box


FREE_REGION = """
const v = window.studio.view, c = v.canvas.getBoundingClientRect();
const bar = document.querySelector('#toolbar').getBoundingClientRect();
const box = document.querySelector('#cell-edit').getBoundingClientRect();
const key = document.querySelector('#stage .legend').getBoundingClientRect();
const cells = [];
for (const p of v.parts) for (let f = 0; f < p.n; f++) { const s = v.screenOf(p.id, f); cells.push([s.x, s.y]); }
return {canvas: [c.left, c.top, c.right, c.bottom], bar: bar.bottom, boxes: [box, key].map(r => [r.left, r.top, r.right, r.bottom]),
        cells};
"""
CAMERA = "const v = window.studio.view; return [v.camera.position.toArray(), v.controls.target.toArray()];"


def _hidden_cells(seen, margin=4):
    """The cells drawn outside the canvas, under the toolbar, the selection box or the legend."""
    left, top, right, bottom = seen["canvas"]
    out = []
    for x, y in seen["cells"]:
        if not (left + margin <= x <= right - margin and max(top, seen["bar"]) + margin <= y <= bottom - margin):
            out.append((x, y))
        elif any(bl - margin <= x <= br + margin and bt - margin <= y <= bb + margin for bl, bt, br, bb in seen["boxes"]):
            out.append((x, y))
    return out


@pytest.mark.parametrize("name", ["cymatic_string", "cymatic_sheet", "hyper_4d"])
def test_every_cell_is_in_view_at_start(tmp_path, name):
    with patch_page(tmp_path, name, f"start_{name}") as driver:
        time.sleep(0.5)
        seen = driver.execute_script(FREE_REGION)
    hidden = _hidden_cells(seen)
    assert not hidden, f"{len(hidden)} of {len(seen['cells'])} cells hidden at start, e.g. {hidden[:5]}"


def test_the_block_camera_shows_everything_keeps_the_users_view_and_zooms_to_the_cursor(tmp_path):
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.actions.wheel_input import ScrollOrigin
    from selenium.webdriver.support.ui import Select

    with patch_page(tmp_path, "cymatic_block", "camera") as driver:
        time.sleep(0.5)
        start = driver.execute_script(FREE_REGION)
        framed = driver.execute_script(CAMERA)
        canvas = driver.find_element("css selector", "#view")
        # the designer turns the block (a drag) then picks a layer, the top view and the 3-D view again
        ActionChains(driver).move_to_element_with_offset(canvas, 0, 0).click_and_hold().move_by_offset(80, 30) \
            .release().perform()
        turned = driver.execute_script(CAMERA)
        Select(driver.find_element("css selector", "#layer")).select_by_index(3)
        after_layer = driver.execute_script(CAMERA)
        Select(driver.find_element("css selector", "#look")).select_by_value("top")
        top_view = driver.execute_script(CAMERA)
        Select(driver.find_element("css selector", "#look")).select_by_value("3d")
        back = driver.execute_script(CAMERA)
        # a wheel turned over a point off the centre: the point under the cursor stays there
        x, y = 150, -90
        driver.execute_script(
            "const v = window.studio.view, r = v.canvas.getBoundingClientRect(), c = v.camera;"
            "const p = c.position.clone().set(2 * (arguments[0] + r.width / 2) / r.width - 1,"
            "  1 - 2 * (arguments[1] + r.height / 2) / r.height, 0.5).unproject(c);"
            "window.aimed = p; window.before = c.position.distanceTo(v.controls.target);", x, y)
        ActionChains(driver).scroll_from_origin(ScrollOrigin.from_element(canvas, x, y), 0, -300).perform()
        time.sleep(0.3)
        zoom = driver.execute_script(
            "const v = window.studio.view, r = v.canvas.getBoundingClientRect(), q = window.aimed.clone().project(v.camera);"
            "return [(q.x + 1) / 2 * r.width - r.width / 2, (1 - q.y) / 2 * r.height - r.height / 2,"
            "        window.before, v.camera.position.distanceTo(v.controls.target)];")
    hidden = _hidden_cells(start)
    assert not hidden, f"{len(hidden)} of {len(start['cells'])} cells hidden at start, e.g. {hidden[:5]}"
    assert turned != framed, turned                                      # the drag turned it
    assert after_layer == turned, (turned, after_layer)
    assert top_view[0][1] > 5 and abs(top_view[0][0] - top_view[1][0]) < 1e-3 < top_view[0][1], top_view
    assert all(abs(a - b) < 1e-6 for a, b in zip(back[0] + back[1], turned[0] + turned[1])), (turned, back)
    assert zoom[3] < 0.95 * zoom[2], zoom                              # it zoomed in
    assert abs(zoom[0] - x) < 3 and abs(zoom[1] - y) < 3, zoom         # towards the cursor


SKIN_AREA = """
const p = window.studio.view.parts[0], g = p.skin.geometry, x = g.attributes.position.array, ix = g.index.array;
let area = 0;
for (let i = 0; i < ix.length; i += 3) {
  const [a, b, c] = [ix[i], ix[i + 1], ix[i + 2]];
  area += Math.abs((x[3*b] - x[3*a]) * (x[3*c+2] - x[3*a+2]) - (x[3*c] - x[3*a]) * (x[3*b+2] - x[3*a+2])) / 2;
}
return area;
"""


def test_the_stage_has_a_legend_named_microphones_and_true_marks_for_locked_cut_and_heavy_cells(tmp_path):
    with patch_page(tmp_path, "cymatic_sheet", "marks") as driver:
        # every microphone named on the stage, beside its line
        until(lambda: driver.execute_script(
            "return [...document.querySelectorAll('#stage .label.mic')].filter(e => e.style.display !== 'none').length === 2"),
            10, "no microphone labels")
        mics = driver.execute_script(
            "const v = window.studio.view, up = v.canvas.parentElement.getBoundingClientRect();"
            "return window.studio.desc.microphones.map(m => { const e = [...document.querySelectorAll('#stage .label.mic')]"
            "  .find(e => e.textContent === m.block), r = e.getBoundingClientRect(), s = v.screenOf(m.lattice, m.flat);"
            "  return [m.block, (r.left + r.right) / 2 - s.x, r.bottom - s.y]; })")
        whole = driver.execute_script(SKIN_AREA)
        # cells (2, 3) and (2, 4) cut, (5, 5) and (0, 0) locked, (7, 9) four times heavier
        assert send(driver, {"cmd": "cut", "cells": ["sheet[2, 3]", "sheet[2, 4]"]})["ok"]
        assert send(driver, {"cmd": "lock", "cells": ["sheet[5, 5]", "sheet[0, 0]"]})["ok"]
        assert send(driver, {"cmd": "cells", "block": "sheet", "cells": [[7, 9]], "mass": 0.002})["ok"]
        until(lambda: driver.execute_script("return window.studio.desc.lattices[0].cells.length === 1"), 60, "no mass edit")
        time.sleep(0.3)
        cut = driver.execute_script(SKIN_AREA)
        marks = driver.execute_script(
            "const p = window.studio.view.parts[0], o = p.overlays;"
            "const cells = (k) => o[k] && o[k].visible ? [...o[k].geometry.index.array] : [];"
            "return {locked: cells('locked'), lockedMap: !!(o.locked && o.locked.material.map),"
            " lockedSize: o.locked.material.size, cellSize: p.points.material.size,"
            " heavy: Object.keys(o).filter(k => k.startsWith('mass')).map(k => [cells(k), o[k].material.size, !!o[k].material.map])};")
        legend = driver.execute_script(
            "const l = document.querySelector('#stage .legend'); return l && l.getBoundingClientRect().width > 0 ? l.innerText : ''")
    for name, dx, dy in mics:
        assert abs(dx) < 40 and -160 < dy < 0, (name, dx, dy)          # above its cell, centred on it
    # a cut cell takes away its own tile, one spacing square each: the hole is the cut, not more
    assert whole == pytest.approx(12 * 16, abs=1e-3), whole
    assert whole - cut == pytest.approx(2.0, abs=1e-3), (whole, cut)
    assert sorted(marks["locked"]) == [0, 5 * 16 + 5], marks
    assert marks["lockedMap"] and marks["lockedSize"] > marks["cellSize"], marks     # a marker, not a dark dot
    assert [h[0] for h in marks["heavy"]] == [[7 * 16 + 9]], marks
    assert marks["heavy"][0][1] > marks["cellSize"] and marks["heavy"][0][2], marks    # larger: heavier
    for words in ("microphone", "excitation", "locked", "cut", "mass", "join", "up", "down"):
        assert words in legend, (words, legend)


def test_a_waveguide_patch_is_drawn_on_the_stage_and_the_modes_tab_says_what_it_can(tmp_path):
    with patch_page(tmp_path, "fig8_pluck_damp", "waveguide") as driver:
        time.sleep(0.5)
        drawn = driver.execute_script(
            "const w = window.studio.view.waveguide, c = window.studio.view.canvas.getBoundingClientRect();"
            "if (!w) return null;"
            "const seen = (e) => { const r = e.getBoundingClientRect(); return e.style.display !== 'none'"
            "  && r.left >= c.left && r.right <= c.right && r.top >= c.top && r.bottom <= c.bottom; };"
            "return {loop: w.layout.loop, samples: w.layout.samples, delays: w.layout.delays.map(d => [d.block, d.length]),"
            " nodes: Object.fromEntries(w.layout.nodes.map(n => [n.block, [n.x, n.z, n.onLoop]])),"
            " labels: [...document.querySelectorAll('#stage .label.wg')].filter(seen).map(e => e.textContent),"
            " meshes: w.group.children.length, legend: document.querySelector('#stage .legend').innerText};")
        tab(driver, "modes")
        modes = until(lambda: driver.execute_script("return document.querySelector('#modes-list').innerText"), 10,
                      "the modes tab is empty")
        driver.find_element("css selector", "#modes-go").click()
        time.sleep(1.0)
        after = driver.execute_script("return document.querySelector('#modes-list').innerText")
    assert drawn is not None, "nothing drawn for the waveguide"
    # the string's round trip: nut -> r1 -> j -> r2 -> r3 -> bridge -> l3 -> l2 -> j -> l1 -> nut
    assert drawn["loop"] == ["nut", "r1", "j", "r2", "r3", "bridge", "l3", "l2", "j", "l1"], drawn["loop"]
    assert sorted(drawn["delays"]) == [["l1", 11], ["l2", 26], ["l3", 11], ["r1", 11], ["r2", 27], ["r3", 11]]
    assert drawn["samples"] == 97
    nodes = drawn["nodes"]
    # folded in two: the nut at one end, the bridge at the other, the junction 11 samples from the nut
    assert nodes["nut"][0] < nodes["j"][0] < nodes["bridge"][0], nodes
    assert nodes["j"][0] - nodes["nut"][0] == pytest.approx(11, abs=0.01), nodes
    assert nodes["bridge"][0] - nodes["nut"][0] == pytest.approx(97 / 2, abs=1), nodes
    assert all(nodes[b][2] for b in ("nut", "j", "bridge")) and not nodes["finger"][2], nodes
    assert set(nodes) == {"nut", "j", "bridge", "finger", "xs", "tip", "contact", "pad_R", "pad", "mic", "out"}
    for text in ("r1 · 11 samples", "r2 · 27 samples", "l2 · 26 samples", "j: explicit_junction", "finger: haptic",
                 "mic: mic"):
        assert text in drawn["labels"], (text, drawn["labels"])       # labelled, and inside the stage
    assert "delay line" in drawn["legend"] and "locked" not in drawn["legend"], drawn["legend"]    # the waveguide's own
    assert "lattice" in modes and "97 samples" in modes, modes
    assert after == modes, after                                       # Compute says the same, not nothing


@pytest.mark.parametrize("name, loop", [
    ("fig7_bowed_string", ["nut", "r1", "j", "r2", "bridge", "l1", "j", "l2"]),    # the bow off the loop, above j
    ("feedback_comb", ["mix", "line", "fb"]),                                      # mix and fb both at the turn
])
def test_other_waveguides_take_no_detour_and_no_two_blocks_share_a_place(tmp_path, name, loop):
    with patch_page(tmp_path, name, f"waveguide_{name}") as driver:
        layout = until(lambda: driver.execute_script(
            "const w = window.studio.view.waveguide; return w && w.layout"), 10, "nothing drawn")
    assert layout["loop"] == loop, layout["loop"]
    places = [(n["block"], n["x"], n["z"]) for n in layout["nodes"]]
    for i, (a, xa, za) in enumerate(places):
        for b, xb, zb in places[i + 1:]:
            assert abs(xa - xb) > 1 or abs(za - zb) > 1, (a, b, places)
