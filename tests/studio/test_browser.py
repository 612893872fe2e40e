"""The studio in a real browser (issue 22, item 10): `hapticgraph studio` on loopback, Debian's
chromium driven by Selenium. The page draws the running instrument (the canvas is not blank and
new frames keep coming), a click on a cell moves a microphone (and the saved patch, and the sound
rendered from it, change accordingly), a slider moves a live parameter, and a bad edit shows the
loader's FILE:LINE: message and changes nothing. Screenshots are kept as artifacts."""
import io
import pathlib
import re
import shutil
import statistics
import time

import numpy as np
import pytest

from browser_env import artifacts, browser_or_skip, chromium, open_page, send, studio, until

ROOT = pathlib.Path(__file__).resolve().parents[2]
SHEET = ROOT / "patches" / "cymatic_sheet.yaml"
MIC_LINE = "  - sheet[8, 11].velocity -> mic1.in\n"
# Frames drawn per second that the test asks for. Not a speed goal (benchmarks/studio_fps.py
# measures that against 30 frames/s): this machine rasterises WebGL in software (SwiftShader) on
# cores shared with other test workers, and the server offers 60 frames/s. At 5 frames/s the page
# demonstrably keeps drawing new cell data from the running session, one frame per 200 ms, which
# a stalled page (one frame, then nothing) or a page drawing without data (0) cannot reach.
FPS_FLOOR = 5.0


@pytest.fixture
def sheet_patch(tmp_path):
    browser_or_skip()
    patch = tmp_path / "sheet.yaml"
    shutil.copyfile(SHEET, patch)
    assert MIC_LINE in patch.read_text()
    return patch


def _canvas_pixels(driver):
    from PIL import Image

    png = driver.find_element("css selector", "#view").screenshot_as_png
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=float)


def test_page_draws_the_running_instrument(sheet_patch, tmp_path):
    out = artifacts(tmp_path, "studio_draws")
    with studio(sheet_patch, out) as url, chromium(out) as driver:
        open_page(driver, url)
        assert send(driver, {"cmd": "restart"})["ok"]       # the pluck again, now that the page looks
        time.sleep(1.0)
        driver.save_screenshot(str(out / "studio_sheet.png"))
        pixels = _canvas_pixels(driver)
        info = driver.execute_script(
            "return [window.studio.desc.lattices.map(l => [l.name, l.shape]), window.studio.view.parts[0].peak]")
        readings = []
        for _ in range(4):
            time.sleep(1.05)
            readings.append(driver.execute_script("return window.studio.fps"))
    assert info[0] == [["sheet", [12, 16]]]
    assert info[1] > 1e-9, "the sheet never moved: no cell frame with displacement arrived"
    # not blank: the canvas has the instrument's colours, not one background colour
    colours = np.unique(pixels.reshape(-1, 3) // 8, axis=0)
    assert pixels.std() > 5.0 and len(colours) > 50, (pixels.std(), len(colours))
    assert statistics.median(readings) >= FPS_FLOOR, readings


def _numbers(value):
    """The numbers in a nested list of script results, flat (booleans left out)."""
    if isinstance(value, list):
        return [x for v in value for x in _numbers(v)]
    return [] if isinstance(value, bool) else [value]


def _steady(driver, script, *args, ok=lambda value: True):
    """The value of `script` once the view has settled: within 2 px on three reads 0.2 s apart
    (the cells move as the sheet sounds) and `ok`. The side panels fill in after the page is ready
    and may narrow the canvas, which moves every cell."""
    seen = []
    end = time.monotonic() + 30
    while True:
        seen.append(driver.execute_script(script, *args))
        last = [_numbers(v) for v in seen[-3:]]
        if len(last) == 3 and ok(seen[-1]) and all(
                max(abs(a - b) for a, b in zip(last[0], other)) <= 2 for other in last[1:]):
            return seen[-1]
        assert time.monotonic() < end, f"the view did not settle: last reads {seen[-3:]}"
        time.sleep(0.2)


def _place_by_click(driver, block, cell_index):
    """Chooses the microphone tool and `block`, then clicks the cell where the page draws it,
    once the view has settled and the page's own picking finds the cell there."""
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.support.ui import Select

    Select(driver.find_element("css selector", "#tool")).select_by_value("mic")
    Select(driver.find_element("css selector", "#place-which")).select_by_value(block)
    canvas = driver.find_element("css selector", "#view")
    x, y, _ = _steady(driver, (
        "const v = window.studio.view, l = window.studio.desc.lattices[0];"
        "const flat = arguments[0].reduce((a, i, k) => a * l.shape[k] + i, 0);"
        "const p = v.screenOf(l.id, flat), r = v.canvas.getBoundingClientRect();"
        "const hit = v.pick(p.x, p.y);"
        "return [Math.round(p.x - r.left - r.width / 2), Math.round(p.y - r.top - r.height / 2),"
        "        hit !== null && hit.lattice === l.id && hit.flat === flat];"), cell_index, ok=lambda v: v[2])
    ActionChains(driver).move_to_element_with_offset(canvas, x, y).click().perform()


def _where_is(driver, block):
    """The cell the page shows `block` on, and the error it shows (for a failure's message)."""
    return driver.execute_script(
        "const m = window.studio.desc.microphones.find(m => m.block === arguments[0]);"
        "const e = document.querySelector('#error');"
        "return [m ? m.cell : null, e && !e.hidden ? e.textContent : ''];", block)


def test_a_click_on_a_cell_moves_the_microphone_into_the_saved_patch_and_the_sound(sheet_patch, tmp_path):
    import hapticgraph

    original = sheet_patch.read_text()
    out = artifacts(tmp_path, "studio_mic")
    with studio(sheet_patch, out) as url, chromium(out) as driver:
        open_page(driver, url)
        _place_by_click(driver, "mic1", [2, 3])
        # a swap: a new kernel compiles first
        until(lambda: _where_is(driver, "mic1")[0] == "sheet[2, 3]", 120,
              lambda: f"mic1 did not move to the clicked cell: (cell, error) = {_where_is(driver, 'mic1')}")
        driver.save_screenshot(str(out / "studio_mic_moved.png"))
        driver.find_element("css selector", "#save").click()
        until(lambda: driver.find_element("css selector", "#save-dialog").is_displayed(), 20, "no save dialog")
        diff = driver.find_element("css selector", "#save-diff").text
        driver.save_screenshot(str(out / "studio_save_diff.png"))
        assert "+  - sheet[2, 3].velocity -> mic1.in" in diff, diff
        assert "-  - sheet[8, 11].velocity -> mic1.in" in diff, diff
        driver.find_element("css selector", "#save-confirm").click()
        until(lambda: sheet_patch.read_text() != original, 20, "the patch file was not written")
    saved = sheet_patch.read_text()
    assert saved == original.replace(MIC_LINE, "  - sheet[2, 3].velocity -> mic1.in\n")
    # the sound of the saved patch is the sound of a microphone on sheet[2, 3]
    by_hand = tmp_path / "by_hand.yaml"
    by_hand.write_text(original.replace("sheet[8, 11].velocity -> mic1.in", "sheet[2, 3].velocity -> mic1.in"))
    before = hapticgraph.render(hapticgraph.load(SHEET), seconds=0.25).audio
    after = hapticgraph.render(hapticgraph.load(sheet_patch), seconds=0.25).audio
    expected = hapticgraph.render(hapticgraph.load(by_hand), seconds=0.25).audio
    assert np.array_equal(after, expected)
    assert np.abs(after - before).max() > 1e-3 * np.abs(before).max()


def test_a_slider_moves_a_live_parameter(sheet_patch, tmp_path):
    from selenium.webdriver.common.keys import Keys

    out = artifacts(tmp_path, "studio_slider")
    with studio(sheet_patch, out) as url, chromium(out) as driver:
        open_page(driver, url)
        slider = driver.find_element("css selector", "#param-mic1-pan-slider")
        slider.send_keys(*[Keys.ARROW_RIGHT] * 50)          # a range input sends input + change
        # pan is declared on [-1, 1]: a linear slider of 1000 steps; 50 steps right of -0.5
        position = int(slider.get_attribute("value"))
        assert position == 300, position
        target = -0.4
        until(lambda: driver.execute_script("return Number(document.querySelector('#param-mic1-pan').value)") == target,
              20, "the number beside the slider does not show the new pan")

        def pan_now():
            reply = send(driver, {"cmd": "describe"})
            return next(p["value"] for p in reply["result"]["params"] if (p["block"], p["param"]) == ("mic1", "pan"))
        until(lambda: abs(pan_now() - target) < 1e-9, 20, f"mic1.pan did not follow the slider to {target}")
        text = send(driver, {"cmd": "state"})["result"]["text"]
        driver.save_screenshot(str(out / "studio_slider.png"))
    assert re.search(r"mic1:\s+\{type: mic, gain: 2\.0, pan: " + re.escape(repr(target)) + r"\}", text), text


def test_a_bad_edit_shows_the_loaders_error_and_changes_nothing(sheet_patch, tmp_path):
    from selenium.webdriver.common.keys import Keys

    out = artifacts(tmp_path, "studio_error")
    with studio(sheet_patch, out) as url, chromium(out) as driver:
        open_page(driver, url)
        before = send(driver, {"cmd": "state"})["result"]["text"]
        box = driver.find_element("css selector", "#param-sheet-tension")
        box.clear()
        box.send_keys("1e9", Keys.ENTER)
        error = driver.find_element("css selector", "#error")
        until(error.is_displayed, 20, "no error shown for an unstable tension")
        driver.save_screenshot(str(out / "studio_error.png"))
        message = error.text
        after = send(driver, {"cmd": "state"})["result"]
    assert re.match(r"^.*sheet\.yaml:\d+: .*sheet", message), message
    assert after["text"] == before and after["undo"] == 0


def test_the_page_plays_the_sound_it_is_sent(sheet_patch, tmp_path):
    """--audio browser: the page's AudioWorklet gets the audio frames and plays them (the ring
    buffer it reports has filled), and what arrived is the instrument's sound, not silence."""
    out = artifacts(tmp_path, "studio_audio")
    with studio(sheet_patch, out, audio="browser") as url, chromium(out) as driver:
        open_page(driver, url)
        assert driver.execute_script("return window.studio.desc.audio.mode") == "browser"
        driver.execute_script(
            "window.heard = 0; window.studio.link.on('audio', (f) => {"
            " for (const x of f.data) window.heard = Math.max(window.heard, Math.abs(x)); });")
        driver.find_element("css selector", "#sound").click()
        assert send(driver, {"cmd": "restart"})["ok"]
        until(lambda: driver.execute_script("return window.studio.audio.buffered > 0"), 30,
              "the worklet never had audio to play")
        time.sleep(1.0)
        stats = driver.execute_script("return window.studio.audio")
        heard = driver.execute_script("return window.heard")
        label = driver.find_element("css selector", "#sound").text
    assert label == "Sound off"
    assert stats["blocks"] > 20, stats
    assert heard > 1e-4, heard


def test_box_select_lock_cut_undo_and_a_mode_shape(sheet_patch, tmp_path):
    """The luthier's tools by hand: a shift-drag box selects cells, Lock and Cut write them into
    the patch (`lock:`, `cut:`), Undo takes the cut back; Modes lists the sheet's modes and a
    click draws one on the instrument."""
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.keys import Keys
    from selenium.webdriver.support.ui import Select

    out = artifacts(tmp_path, "studio_tools")
    with studio(sheet_patch, out) as url, chromium(out) as driver:
        open_page(driver, url)
        Select(driver.find_element("css selector", "#look")).select_by_value("top")   # rows and columns on screen axes
        corners = _steady(driver,
            "const v = window.studio.view, r = v.canvas.getBoundingClientRect();"
            "return [[0, 0], [2, 3], [0, 1]].map(([i, j]) => v.screenOf(0, i * 16 + j))"
            ".map((p) => [Math.round(p.x - r.left - r.width / 2), Math.round(p.y - r.top - r.height / 2)]);")
        (x0, y0), (x1, y1), (xn, yn) = corners
        # the box's edges halfway to the next row and column: the cells may move a few pixels
        pad = 0.5 * ((xn - x0) ** 2 + (yn - y0) ** 2) ** 0.5
        ActionChains(driver).move_to_element_with_offset(driver.find_element("css selector", "#view"),
                                                         round(min(x0, x1) - pad), round(min(y0, y1) - pad)) \
            .key_down(Keys.SHIFT).click_and_hold().move_by_offset(round(abs(x1 - x0) + 2 * pad), round(abs(y1 - y0) + 2 * pad)) \
            .release().key_up(Keys.SHIFT).perform()
        chosen = driver.execute_script("return window.studio.tools.selection.map((c) => c.flat).sort((a, b) => a - b)")
        assert chosen == sorted(i * 16 + j for i in range(3) for j in range(4)), chosen   # the pluck's sheet[3, 4] left out
        driver.find_element("css selector", "#lock").click()
        until(lambda: len(driver.execute_script("return window.studio.desc.lattices[0].locked")) == 12, 120, "no lock")
        driver.find_element("css selector", "#cut").click()
        until(lambda: len(driver.execute_script("return window.studio.desc.lattices[0].cut")) == 12, 120, "no cut")
        text = send(driver, {"cmd": "state"})["result"]["text"]
        driver.save_screenshot(str(out / "studio_cut.png"))
        driver.find_element("css selector", "#undo").click()
        until(lambda: driver.execute_script("return window.studio.desc.lattices[0].cut.length") == 0, 120, "undo")
        driver.find_element("css selector", "#tabs button[data-tab=modes]").click()
        driver.find_element("css selector", "#modes-go").click()
        until(lambda: len(driver.find_elements("css selector", "#modes-list tr.mode")) == 10, 60, "no modes listed")
        driver.find_elements("css selector", "#modes-list tr.mode")[1].click()
        until(lambda: driver.execute_script("return window.studio.view.parts[0].peak > 0.5"), 30, "mode 2 not drawn")
        driver.save_screenshot(str(out / "studio_mode.png"))
        frames_after_cut = driver.execute_script("return window.studio.link.received")
        time.sleep(1.5)
        frames_later = driver.execute_script("return window.studio.link.received")
    assert re.search(r"lock: \[\[0, 0\], \[0, 1\],", text) and re.search(r"cut: \[\[0, 0\], \[0, 1\],", text), text
    assert frames_later > frames_after_cut, "the running sound stopped sending cells after the cut"


def test_a_microphone_placed_inside_a_block(tmp_path):
    """Cymatic listens from inside a block: with one layer of patches/cymatic_block.yaml shown, a
    click on an inner cell moves mic2 there."""
    from selenium.webdriver.support.ui import Select

    browser_or_skip()
    patch = tmp_path / "block.yaml"
    shutil.copyfile(ROOT / "patches" / "cymatic_block.yaml", patch)
    out = artifacts(tmp_path, "studio_block")
    with studio(patch, out) as url, chromium(out) as driver:
        open_page(driver, url)
        assert driver.execute_script("return window.studio.view.parts[0].kind") == "block"
        Select(driver.find_element("css selector", "#layer")).select_by_visible_text("blk[2, :, :]")
        _place_by_click(driver, "mic2", [2, 3, 4])
        until(lambda: _where_is(driver, "mic2")[0] == "blk[2, 3, 4]", 120,
              lambda: f"mic2 did not move to the inner cell clicked: (cell, error) = {_where_is(driver, 'mic2')}")
        driver.save_screenshot(str(out / "studio_block_layer.png"))
        text = send(driver, {"cmd": "state"})["result"]["text"]
    assert "  - blk[2, 3, 4].velocity -> mic2.in\n" in text


def test_the_mapping_dialog_writes_map(tmp_path):
    """The gesture-mapping dialog shows the patch's map: entries and writes an edited one back:
    the text changes only in the value edited."""
    browser_or_skip()
    patch = tmp_path / "melody.yaml"
    shutil.copyfile(ROOT / "patches" / "midi_melody.yaml", patch)
    shutil.copyfile(ROOT / "patches" / "melody.mid", tmp_path / "melody.mid")
    before = patch.read_text()
    line = "  - {param: tone.amplitude, cc: 74, min: 0.1, max: 0.5, curve: exponential, smooth: 0.01}\n"
    assert line in before
    out = artifacts(tmp_path, "studio_mapping")
    with studio(patch, out) as url, chromium(out) as driver:
        open_page(driver, url)
        driver.find_element("css selector", "#mapping-open").click()
        rows = driver.find_elements("css selector", "#mapping-table tbody tr")
        assert len(rows) == 1
        assert rows[0].find_element("css selector", "[name=address]").get_attribute("value") == "74"
        top = rows[0].find_element("css selector", "[name=max]")
        top.clear()
        top.send_keys("0.4")
        driver.save_screenshot(str(out / "studio_mapping.png"))
        driver.find_element("css selector", "#mapping-write").click()
        until(lambda: driver.execute_script("return window.studio.desc.map[0].max") == 0.4, 120, "map: not written")
        text = send(driver, {"cmd": "state"})["result"]["text"]
    assert text == before.replace(line, line.replace("max: 0.5", "max: 0.4"))
