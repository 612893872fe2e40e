"""The page keeps the designer's work (issue 33, item 3) in a real browser: a socket the server
drops is opened again by the page itself (the same studio, the edits still there); while the
studio is gone the page says so and downloads the edited text; the next studio of the patch
offers the edits the killed one had, and Recover brings them back."""
import shutil

import pytest

from browser_env import artifacts, browser_or_skip, chromium, open_page, send, until
from project_env import ROOT
from hapticgraph.studio.server import MAX_MESSAGE
from studio_proc import Studio


@pytest.fixture
def sheet_patch(tmp_path):
    browser_or_skip()
    patch = tmp_path / "sheet.yaml"
    shutil.copyfile(ROOT / "patches" / "cymatic_sheet.yaml", patch)
    return patch


def _shown(driver, selector):
    return driver.execute_script("const e = document.querySelector(arguments[0]); return !!e && !e.hidden"
                                 " && (e.open === undefined || e.open);", selector)


def test_reconnect_download_while_gone_and_recover_on_the_next_start(sheet_patch, tmp_path):
    out = artifacts(tmp_path, "studio_recovery")
    downloads = tmp_path / "downloads"
    downloads.mkdir()
    first = Studio(sheet_patch)
    second = None
    try:
        with chromium(out) as driver:
            driver.execute_cdp_cmd("Browser.setDownloadBehavior", {"behavior": "allow", "downloadPath": str(downloads)})
            open_page(driver, first.page)
            assert send(driver, {"cmd": "set", "block": "mic1", "param": "gain", "value": 1.5})["ok"]
            edited = send(driver, {"cmd": "state"})["result"]["text"]
            assert driver.find_element("css selector", "#save").text == "Save… *"

            # a dropped socket (the server closes it on a message over its limit): the page reconnects
            driver.execute_script("window.studio.link.ws.send('x'.repeat(arguments[0]))", MAX_MESSAGE + 1)
            until(lambda: driver.execute_script("return window.studio.link.opened") == 2, 30,
                  "the page did not open the connection again")
            until(lambda: not _shown(driver, "#offline"), 30, "the page still says it is disconnected")
            again = send(driver, {"cmd": "state"})["result"]
            assert again["text"] == edited and again["undo"] == 1

            # the studio killed: the page says so and still downloads the edited text
            first.kill()
            until(lambda: _shown(driver, "#offline"), 30, "the page does not say the studio is gone")
            banner = driver.find_element("css selector", "#offline").text
            driver.save_screenshot(str(out / "studio_offline.png"))
            assert "1 unsaved edit" in banner and ".sheet.yaml.studio~" in banner, banner
            driver.find_element("css selector", "#offline-download").click()
            until(lambda: (downloads / "sheet.yaml").is_file(), 20, "nothing downloaded")
            until(lambda: (downloads / "sheet.yaml").read_text() == edited, 20, "the download is not the edited text")

            # the next studio offers the edits; Recover brings them back
            second = Studio(sheet_patch)
            open_page(driver, second.page)
            until(lambda: _shown(driver, "#recovery-dialog"), 30, "no recovery offered")
            offer = driver.find_element("css selector", "#recovery-dialog").text
            driver.save_screenshot(str(out / "studio_recovery_offer.png"))
            assert "Recover 1 unsaved edit" in offer and "gain: 1.5" in offer, offer
            driver.find_element("css selector", "#recovery-accept").click()
            until(lambda: driver.execute_script("return window.studio.desc.text") == edited, 60, "not recovered")
            until(lambda: not _shown(driver, "#recovery-dialog"), 10, "the offer is still shown")
            assert driver.find_element("css selector", "#save").text == "Save… *"
            assert driver.find_element("css selector", "#undo").text == "Undo (1)"
    finally:
        first.kill()
        if second is not None:
            second.kill()
