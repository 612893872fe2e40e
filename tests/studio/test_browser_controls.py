"""The studio's controls as a designer meets them (issue 33, item 4, the controls half), walked
through in a real browser with the mouse: sliders that can be dragged and show what is in effect,
refusals beside the control, edits shown pending, a lattice-less patch's tools, undo after a
runaway, a join's tension asked, one drag one undo entry, tooltips and the help overlay, no 404.
`hapticgraph studio` on loopback, Debian's chromium through Selenium."""
import time

from browser_env import patch_page, send, until


def in_effect(driver, block, param):
    """The parameter's value as the server has it (what the sound plays)."""
    reply = send(driver, {"cmd": "describe"})
    return next(p for p in reply["result"]["params"] if (p["block"], p["param"]) == (block, param))


def shown(driver, block, param):
    """[the number box's value, the value the slider's position stands for, the slider element]."""
    return driver.execute_script(
        "const c = window.studio.params.controls.get(arguments[0]);"
        "return [Number(c.box.value), c.sliderValue(), c.slider];", f"{block}.{param}")


def drag(driver, slider, start_px, steps, step_px, pause=0.15):
    """Press the slider `start_px` from its left end, move `steps` times by `step_px`, release."""
    from selenium.webdriver.common.action_chains import ActionChains

    width = slider.rect["width"]
    chain = ActionChains(driver, duration=20).move_to_element_with_offset(slider, round(start_px - width / 2), 0)
    chain.click_and_hold()
    for _ in range(steps):
        chain.move_by_offset(step_px, 0).pause(pause)
    chain.release().perform()


def test_a_lattice_slider_drags_stays_inside_the_bound_and_shows_what_is_in_effect(tmp_path):
    from selenium.webdriver.common.keys import Keys

    with patch_page(tmp_path, "cymatic_string", "controls_slider") as driver:
        # the mass: each step changes the tension's stability bound; the slider stays under the mouse
        _, _, slider = shown(driver, "str", "mass")
        start = in_effect(driver, "str", "mass")["value"]
        drag(driver, slider, 40, 10, 25)
        until(lambda: abs(in_effect(driver, "str", "mass")["value"] - shown(driver, "str", "mass")[0]) < 1e-12, 60,
              lambda: f"the mass in effect {in_effect(driver, 'str', 'mass')} is not the one shown "
                      f"{shown(driver, 'str', 'mass')[:2]}")
        box, at, same = shown(driver, "str", "mass")
        assert driver.execute_script("return arguments[0].isConnected && arguments[0] === arguments[1]", slider, same)
        assert abs(at - box) <= 1e-9 + 0.01 * box, (at, box)
        # 250 px of a ~200 px track's log range: far more than the first step (one rebuild stops it there)
        assert box > 20 * start, (start, box)

        # the tension's top: strictly inside the stability bound, so accepted
        _, _, slider = shown(driver, "str", "tension")
        drag(driver, slider, slider.rect["width"] / 2, 3, round(slider.rect["width"] / 6 + 10))   # past its right end
        t = until(lambda: (lambda p: p if abs(p["value"] - shown(driver, "str", "tension")[0]) < 1e-9 else None)(
            in_effect(driver, "str", "tension")), 60,
            lambda: f"the tension shown {shown(driver, 'str', 'tension')[:2]} is not in effect "
                    f"{in_effect(driver, 'str', 'tension')}")
        assert t["value"] < t["stable_max"] and t["value"] > 0.99 * t["stable_max"], t
        assert not driver.find_element("css selector", "#error").is_displayed()

        # a refused value: the box and the slider go back to the value in effect, the refusal is
        # said beside the control, and the banner can be dismissed
        before = in_effect(driver, "str", "tension")["value"]
        box = driver.find_element("css selector", "#param-str-tension")
        box.send_keys(Keys.CONTROL, "a")
        box.send_keys("1e9", Keys.ENTER)
        note = until(lambda: driver.execute_script(
            "const n = document.querySelector('#param-str-tension').closest('.param').querySelector('.refusal');"
            "return n && !n.hidden && n.textContent"), 30, "no refusal beside the tension")
        assert "str" in note
        until(lambda: shown(driver, "str", "tension")[0] == before, 10,
              lambda: f"the box keeps the refused value: {shown(driver, 'str', 'tension')[:2]}, in effect {before}")
        assert abs(shown(driver, "str", "tension")[1] - before) <= 0.01 * before
        assert in_effect(driver, "str", "tension")["value"] == before
        banner = driver.find_element("css selector", "#error")
        assert banner.is_displayed()
        driver.find_element("css selector", "#error-close").click()
        until(lambda: not banner.is_displayed(), 5, "the banner was not dismissed")


def cell_on_screen(driver, lattice, flat, deadline_s=30):
    """(x, y) offsets from the canvas's centre where the page draws cell `flat` of `lattice`, once
    its own picking finds that cell there (the side panels may still narrow the canvas)."""
    script = ("const v = window.studio.view, r = v.canvas.getBoundingClientRect();"
              "const p = v.screenOf(arguments[0], arguments[1]), hit = v.pick(p.x, p.y);"
              "return [Math.round(p.x - r.left - r.width / 2), Math.round(p.y - r.top - r.height / 2),"
              "        hit !== null && hit.lattice === arguments[0] && hit.flat === arguments[1]];")
    seen = []

    def steady():
        seen.append(driver.execute_script(script, lattice, flat))
        last = seen[-3:]
        return len(last) == 3 and last[-1][2] and all(abs(a[0] - last[-1][0]) <= 2 and abs(a[1] - last[-1][1]) <= 2
                                                      for a in last)
    until(steady, deadline_s, lambda: f"cell {flat} of lattice {lattice} is not where the page draws it: {seen[-3:]}")
    return seen[-1][0], seen[-1][1]


def click_cell(driver, lattice, flat):
    from selenium.webdriver.common.action_chains import ActionChains

    x, y = cell_on_screen(driver, lattice, flat)
    ActionChains(driver).move_to_element_with_offset(driver.find_element("css selector", "#view"), x, y).click().perform()


def test_an_edit_is_shown_pending_and_a_second_click_meanwhile_adds_nothing(tmp_path):
    from selenium.webdriver.support.ui import Select

    with patch_page(tmp_path, "cymatic_sheet", "controls_pending") as driver:
        Select(driver.find_element("css selector", "#look")).select_by_value("top")
        Select(driver.find_element("css selector", "#tool")).select_by_value("mic")
        Select(driver.find_element("css selector", "#place-which")).select_by_value("")      # + new microphone
        indicator = driver.find_element("css selector", "#pending")
        assert not indicator.is_displayed()
        click_cell(driver, 0, 2 * 16 + 3)
        assert indicator.is_displayed(), "nothing shows that the new microphone is being added"
        began = time.monotonic()
        click_cell(driver, 0, 9 * 16 + 12)                   # a second click while the first lands
        until(lambda: not indicator.is_displayed(), 120, "the edit never landed")
        landed = time.monotonic() - began
        mics = driver.execute_script("return window.studio.desc.microphones.map((m) => [m.block, m.cell])")
        which = driver.execute_script("return document.querySelector('#place-which').value")
        undo = send(driver, {"cmd": "state"})["result"]["undo"]
    assert landed > 0.2, landed          # the second click came while the first was pending
    assert mics == [["mic1", "sheet[8, 11]"], ["mic2", "sheet[5, 13]"], ["mic3", "sheet[2, 3]"]], mics
    assert undo == 1
    # the tool now moves the microphone just placed: a further click adds no other
    assert which == "mic3", which


LATTICE_TOOLS = ("#tool", "#lock", "#unlock", "#cut", "#join", "#clear-selection", "#edit-mass", "#edit-damping",
                 "#edit-tension", "#edit-apply")


def test_a_patch_without_a_lattice_disables_the_lattice_tools_and_says_what_they_apply_to(tmp_path):
    with patch_page(tmp_path, "fig8_pluck_damp", "controls_waveguide") as driver:
        assert driver.execute_script("return window.studio.desc.lattices.length") == 0
        enabled = [s for s in LATTICE_TOOLS if driver.find_element("css selector", s).is_enabled()]
        note = driver.find_element("css selector", "#tools-note")
        shown_note = note.is_displayed() and note.text
        tip = driver.find_element("css selector", "#tool").get_attribute("title")
    assert enabled == [], enabled
    assert shown_note and "lattice" in shown_note and "Parameters" in shown_note, shown_note
    assert "lattice" in tip, tip


def test_a_lattice_patch_has_its_tools(tmp_path):
    with patch_page(tmp_path, "cymatic_string", "controls_lattice_tools") as driver:
        assert driver.find_element("css selector", "#tool").is_enabled()
        assert not driver.find_element("css selector", "#tools-note").is_displayed()


def status_t(driver):
    return driver.execute_script("return window.studio.status ? window.studio.status.t : null")


def test_undo_after_a_runaway_resumes_the_sound(tmp_path):
    from selenium.webdriver.common.keys import Keys

    with patch_page(tmp_path, "cymatic_sheet", "controls_runaway") as driver:
        box = driver.find_element("css selector", "#param-hit-force")
        box.send_keys(Keys.CONTROL, "a")
        box.send_keys("1e6", Keys.ENTER)                    # a strike a million times too hard
        until(lambda: in_effect(driver, "hit", "force")["value"] == 1e6, 20, lambda: f"the force was not set: box {box.get_attribute('value')!r}, in effect {in_effect(driver, 'hit', 'force')}, {driver.find_element('css selector', '#error').text}")
        driver.find_element("css selector", "#restart").click()
        banner = driver.find_element("css selector", "#error")
        until(lambda: banner.is_displayed() and "runaway" in banner.text, 60, "no runaway shown")
        time.sleep(1.2)                                     # a status event since the restart
        stopped = status_t(driver)
        time.sleep(1.5)
        assert status_t(driver) == stopped < 0.1, "the sound went on after the runaway"
        driver.find_element("css selector", "#undo").click()
        until(lambda: in_effect(driver, "hit", "force")["value"] == 0.5, 60, "undo did not take the force back")
        first = until(lambda: (lambda t: t is not None and t != stopped and t)(status_t(driver)), 30,
                      "no status since the undo")
        time.sleep(2.0)
        later = status_t(driver)
        problem = send(driver, {"cmd": "state"})["result"]["problem"]
        shown_banner = banner.is_displayed() and banner.text
    assert later - first > 1.0, (stopped, first, later)
    assert problem is None, problem
    assert not shown_banner, shown_banner


def test_a_join_asks_its_tension_with_the_patchs_own_as_default(tmp_path):
    from selenium.webdriver.common.keys import Keys
    from selenium.webdriver.support.ui import Select

    with patch_page(tmp_path, "string_drives_plate", "controls_join") as driver:
        Select(driver.find_element("css selector", "#look")).select_by_value("top")
        Select(driver.find_element("css selector", "#tool")).select_by_value("join")
        field = driver.find_element("css selector", "#join-tension")
        assert field.is_displayed()
        default, why = float(field.get_attribute("value")), driver.find_element("css selector", "#join-why").text
        field.send_keys(Keys.CONTROL, "a")
        field.send_keys("1500")
        click_cell(driver, 1, 0 * 12 + 2)                    # plate[0, 2] then plate[3, 7]
        click_cell(driver, 1, 3 * 12 + 7)
        joins = until(lambda: (lambda j: len(j) == 2 and j)(driver.execute_script("return window.studio.desc.joins")),
                      120, lambda: f"no join: {driver.find_element('css selector', '#error').text}")
    # the patch's own join (its bridge, 2000 N/m), not the mean of the parts (21350 N/m)
    assert default == 2000.0, default
    assert "bridge" in why and "2000" in why, why
    assert joins[1]["a"] == "plate[0, 2]" and joins[1]["b"] == "plate[3, 7]" and joins[1]["tension"] == 1500.0, joins


def test_one_drag_is_one_undo_entry_and_ctrl_z_works_on_a_focused_slider(tmp_path):
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.keys import Keys

    with patch_page(tmp_path, "cymatic_string", "controls_undo") as driver:
        before = in_effect(driver, "str", "damping")["value"]
        _, _, slider = shown(driver, "str", "damping")
        drag(driver, slider, slider.rect["width"] / 2, 10, 6)
        until(lambda: in_effect(driver, "str", "damping")["value"] == shown(driver, "str", "damping")[0] != before, 60,
              lambda: f"the drag did not land: {shown(driver, 'str', 'damping')[:2]}")
        dragged = in_effect(driver, "str", "damping")["value"]
        undo = send(driver, {"cmd": "state"})["result"]["undo"]
        assert driver.switch_to.active_element == slider
        ActionChains(driver).key_down(Keys.CONTROL).send_keys("z").key_up(Keys.CONTROL).perform()
        until(lambda: in_effect(driver, "str", "damping")["value"] == before, 60, "Ctrl+Z on the slider undid nothing")
        until(lambda: shown(driver, "str", "damping")[0] == before, 10, "the box does not show the undone value")
        at = shown(driver, "str", "damping")[1]
        after_undo = send(driver, {"cmd": "state"})["result"]["undo"]
        ActionChains(driver).key_down(Keys.CONTROL).key_down(Keys.SHIFT).send_keys("z").key_up(Keys.SHIFT) \
            .key_up(Keys.CONTROL).perform()
        until(lambda: in_effect(driver, "str", "damping")["value"] == dragged, 60, "Ctrl+Shift+Z redid nothing")
    assert undo == 1, undo
    assert after_undo == 0
    assert abs(at - before) <= 0.01 * before, (at, before)


FIELDS = ("header button:not([hidden]), header select, #toolbar button, #toolbar select, #toolbar input, "
          "#cell-edit input, #cell-edit button, #tabs button, #tab-params input, #tab-scope input, #tab-scope select, "
          "#tab-modes input, #tab-modes button, #tab-text button, #tab-text textarea, dialog button, dialog input, "
          "dialog select")
SHORTCUTS = {"#undo": "Ctrl+Z", "#redo": "Ctrl+Shift+Z", "#save": "Ctrl+S", "#lock": "(L)", "#unlock": "(U)",
             "#cut": "(X)", "#clear-selection": "(C)", "#join": "(J)", "#restart": "(R)"}
UNITS = {"#edit-mass": "[kg]", "#edit-damping": "[N·s/m]", "#edit-tension": "[N/m]", "#join-tension": "[N/m]",
         "#param-str-mass": "[kg]", "#param-str-tension-slider": "[N/m]", "#param-mic1-pan": "pan"}


def test_every_tool_and_field_has_a_tooltip_and_question_mark_opens_the_help(tmp_path):
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.keys import Keys

    with patch_page(tmp_path, "cymatic_string", "controls_help") as driver:
        driver.find_element("css selector", "#mapping-open").click()          # its rows are made when opened
        driver.find_element("css selector", "#mapping-add").click()
        untitled = driver.execute_script(
            "return [...document.querySelectorAll(arguments[0])].filter((e) => !(e.closest('[title]') || {}).title)"
            ".map((e) => e.id || e.outerHTML.slice(0, 80))", FIELDS)
        title = {s: driver.find_element("css selector", s).get_attribute("title") for s in (*SHORTCUTS, *UNITS)}
        options = [o.text for o in driver.find_elements("css selector", "#tool option")]
        driver.find_element("css selector", "#mapping-cancel").click()
        help_box = driver.find_element("css selector", "#help")
        assert not help_box.is_displayed()
        driver.find_element("css selector", "#title").click()
        ActionChains(driver).send_keys("?").perform()
        until(help_box.is_displayed, 5, "? did not open the help")
        text = help_box.text
        ActionChains(driver).send_keys(Keys.ESCAPE).perform()
        until(lambda: not help_box.is_displayed(), 5, "Esc did not close the help")
        ActionChains(driver).send_keys("m").perform()
        tool = driver.find_element("css selector", "#tool").get_attribute("value")
    assert untitled == [], untitled
    assert {s: t for s, t in title.items() if (SHORTCUTS.get(s) or UNITS[s]) not in t} == {}, title
    assert options == ["Select (V)", "Place microphone (M)", "Place excitation (E)", "Join (J): click two cells"], options
    for key in ("?", "Esc", "V", "M", "E", "J", "L", "U", "X", "C", "R", "Ctrl+Z", "Ctrl+Shift+Z", "Ctrl+S"):
        assert f"\n{key} " in f"\n{text}" or f" {key} " in text, (key, text)
    assert tool == "mic"


def test_the_page_loads_with_no_404_and_a_favicon(tmp_path):
    with patch_page(tmp_path, "cymatic_sheet", "controls_favicon") as driver:
        time.sleep(1.0)                           # the browser asks for the icon after the page
        log = driver.get_log("browser")
        icon = driver.execute_script("const l = document.querySelector('link[rel=icon]'); return l && l.href")
        fetched = driver.execute_async_script(
            "const done = arguments[arguments.length - 1];"
            "fetch(arguments[0]).then(async (r) => done([r.status, r.headers.get('content-type'), (await r.text()).slice(0, 200)]),"
            " (e) => done([0, String(e), '']));", icon) if icon else None
    missing = [e["message"] for e in log if "404" in e["message"] or "Failed to load resource" in e["message"]]
    assert missing == [], missing
    assert icon and icon.endswith(".svg"), icon
    assert fetched[0] == 200 and fetched[1].startswith("image/svg+xml") and "<svg" in fetched[2], fetched


def test_a_refused_cell_edit_goes_back_to_the_value_in_effect(tmp_path):
    from selenium.webdriver.common.keys import Keys
    from selenium.webdriver.support.ui import Select

    with patch_page(tmp_path, "cymatic_sheet", "controls_cell_edit") as driver:
        Select(driver.find_element("css selector", "#look")).select_by_value("top")
        click_cell(driver, 0, 5 * 16 + 6)
        until(lambda: driver.find_element("css selector", "#cell-edit-what").text == "sheet[5, 6]", 10, "no selection")
        mass = driver.find_element("css selector", "#edit-mass")
        mass.send_keys(Keys.CONTROL, "a")
        mass.send_keys("1e-9", Keys.ENTER)                 # far below the smallest stable mass
        note = until(lambda: driver.execute_script(
            "const n = document.querySelector('#cell-edit .refusal'); return n && !n.hidden && n.textContent"), 30,
            "no refusal beside the selection's fields")
        until(lambda: mass.get_attribute("value") == "0.0002", 10,
              lambda: f"the mass field keeps the refused value: {mass.get_attribute('value')}")
        text = send(driver, {"cmd": "state"})["result"]["text"]
    assert "sheet" in note
    assert "cells:" not in text
