#!/usr/bin/python3
"""The dashboard in a real browser: Debian's Chromium, headless, driven by Debian's
python3-selenium through chromium-driver (nothing is downloaded). Run by dashboard_browser_test
against hvac-twin-web, hvac-twind and hvac-twin-sim on loopback, with a leak in the plant:

  1. the overview shows the unit's tile, in words (NORMAL / SUSPECT / LEAK), not colour only;
  2. its values update, and each cycle reaches the page within 1 s of its publication;
  3. the unit view draws its charts and tables and fits a phone's width;
  4. the leak turns the tile to LEAK;
  5. killing the daemon (this script sends SIGKILL to --daemon-pid) turns the tile stale within
     the liveliness lease (3 wall periods) plus 300 ms of checks and delivery;
  6. the browser's console shows no error at any point.

Prints one JSON line of figures on stdout; exit status 0 when every check held, 1 otherwise (the
reasons on stderr)."""
import argparse
import json
import os
import signal
import sys
import time

from selenium import webdriver
from selenium.webdriver.chrome.options import Options
from selenium.webdriver.chrome.service import Service
from selenium.webdriver.common.by import By

failures = []
console = []


def check(ok, what):
    if not ok:
        failures.append(what)
        print("FAILED: " + what, file=sys.stderr, flush=True)
    return ok


def wait_for(driver, condition, timeout_s, poll_s=0.05):
    end = time.monotonic() + timeout_s
    while True:
        try:
            value = condition(driver)
            if value:
                return value
        except Exception:  # the element may not exist yet or be replaced while read
            pass
        if time.monotonic() > end:
            return None
        time.sleep(poll_s)


def drain_console(driver):
    for entry in driver.get_log("browser"):
        console.append(entry)


def tile(driver, unit):
    return driver.find_element(By.CSS_SELECTOR, f'li.tile[data-unit="{unit}"]')


def shown_cycle(driver, unit):
    """The tile's cycle and its shown last cycle, read again if the tile is re-rendered between
    finding an element and reading it (a stale element reference failed CI once)."""
    return wait_for(driver, lambda d: (int(tile(d, unit).get_attribute("data-cycle") or 0),
                                       tile(d, unit).find_element(By.CSS_SELECTOR,
                                                                  ".last-cycle").text), 5) or (0, "")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--url", required=True)
    ap.add_argument("--unit", default="hp1")
    ap.add_argument("--daemon-pid", type=int, required=True)
    ap.add_argument("--period-ms", type=float, required=True, help="the unit's wall period")
    ap.add_argument("--leak-timeout-s", type=float, default=180)
    ap.add_argument("--out-dir", default=".")
    a = ap.parse_args()
    lease_ms = 3 * a.period_ms
    figures = {}

    options = Options()
    options.binary_location = "/usr/bin/chromium"
    for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", "--window-size=1280,900"):
        options.add_argument(arg)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    driver = webdriver.Chrome(service=Service("/usr/bin/chromedriver"), options=options)
    try:
        started = time.monotonic()
        driver.get(a.url)

        # 1. The unit's tile, with its state in words.
        t = wait_for(driver, lambda d: tile(d, a.unit), 30)
        if not check(t is not None, f"no tile for {a.unit} within 30 s"):
            return
        state = t.find_element(By.CSS_SELECTOR, ".state").text
        check(any(w in state for w in ("NORMAL", "SUSPECT", "LEAK")), f"tile state in words: {state!r}")
        check(a.unit in t.text, "the tile names the unit")
        check("Modbus" in t.text and "Last cycle" in t.text, f"tile facts: {t.text!r}")

        # 2. Values update; each new cycle against the moment it was shown: from its publication
        # (the tick's stamp plus the cycle's time, when the daemon writes the health sample; a
        # tick the scheduler ran late makes this figure larger, never smaller) and from its stamp.
        driver.execute_script("""
            window.__lat = []; window.__from_stamp = [];
            new MutationObserver((ms) => { for (const m of ms) {
              const li = m.target;
              if (!li.dataset.publishedMs) continue;
              window.__lat.push(Date.now() - Number(li.dataset.publishedMs));
              window.__from_stamp.push(Date.now() - Number(li.dataset.stampMs));
            } }).observe(document.getElementById('tiles'),
                         {subtree: true, attributes: true, attributeFilter: ['data-cycle']});""")
        # Two 5 s windows at most: a window whose slowest cycle is over the bound is measured
        # again once, and only the second is judged. A host that stalls everything for a second
        # (seen once in CI: the simulator's Modbus replies timing out in the same minute, 454 ms
        # median; alone on the same kind of machine 11 ms median, 220 ms worst) passes; a relay
        # or a page that is slow every cycle fails both windows.
        for window in (1, 2):
            c1, text1 = shown_cycle(driver, a.unit)
            time.sleep(5)
            c2, text2 = shown_cycle(driver, a.unit)
            lat = sorted(driver.execute_script("return window.__lat.splice(0)"))
            from_stamp = sorted(driver.execute_script("return window.__from_stamp.splice(0)"))
            if window == 2 or not lat or lat[-1] < 1000:
                break
            figures["slow_first_window_ms"] = [round(lat[len(lat) // 2]), round(lat[-1])]
            print(f"first window slow (median {lat[len(lat) // 2]:.0f} ms, max {lat[-1]:.0f} ms): "
                  "measuring again", file=sys.stderr, flush=True)
        check(c2 > c1, f"the cycle advanced on the page ({c1} -> {c2})")
        check(text1 != text2, "the shown last cycle changed")
        if check(len(lat) >= 5, f"updates seen in 5 s: {len(lat)}"):
            figures["updates_in_5s"] = len(lat)
            figures["published_to_page_ms_median"] = round(lat[len(lat) // 2])
            figures["published_to_page_ms_max"] = round(lat[-1])
            figures["stamp_to_page_ms_median"] = round(from_stamp[len(from_stamp) // 2])
            figures["stamp_to_page_ms_max"] = round(from_stamp[-1])
            check(lat[-1] < 1000, f"every cycle on the page within 1 s of its publication (max {lat[-1]:.0f} ms)")
        drain_console(driver)

        # 3. The unit view: charts, tables, health; the window buttons; a phone's width.
        tile(driver, a.unit).find_element(By.TAG_NAME, "a").click()
        n = wait_for(driver, lambda d: len(d.find_elements(By.CSS_SELECTOR, "figure.chart svg path")) >= 20
                     and len(d.find_elements(By.CSS_SELECTOR, "figure.chart")), 30)
        check(n is not None and n >= 20, f"the unit view draws its charts ({n})")
        rows = driver.find_elements(By.CSS_SELECTOR, "#points tbody tr")
        check(len(rows) >= 5, f"a row per measured point ({len(rows)})")
        check(len(driver.find_elements(By.CSS_SELECTOR, "#health dt")) >= 10, "health counters shown")
        badges = driver.find_element(By.ID, "unit-status").text
        check("Leak" in badges and "Modbus" in badges and "Estimate" in badges, f"status badges: {badges!r}")
        unlabelled = driver.execute_script(
            "return [...document.querySelectorAll('svg[role=img]')].filter(s => !s.getAttribute('aria-label')).length")
        check(unlabelled == 0, f"every chart has a text alternative ({unlabelled} without)")
        first = driver.find_element(By.CSS_SELECTOR, "#unit-status").text
        driver.find_element(By.CSS_SELECTOR, 'button[data-window="900"]').click()
        check(wait_for(driver, lambda d: d.find_element(By.CSS_SELECTOR, 'button[data-window="900"]')
                       .get_attribute("aria-pressed") == "true", 5) is not None, "the window button is pressed")
        later = wait_for(driver, lambda d: d.find_element(By.CSS_SELECTOR, "#unit-status").text != first
                         and d.find_element(By.CSS_SELECTOR, "#unit-status").text, 10)
        check(later is not None, "the unit view updates live")
        driver.save_screenshot(os.path.join(a.out_dir, "unit.png"))
        driver.set_window_size(390, 844)
        time.sleep(0.5)
        overflow = driver.execute_script("return document.documentElement.scrollWidth - window.innerWidth")
        check(overflow <= 1, f"the unit view fits a phone's width ({overflow} px too wide)")
        driver.save_screenshot(os.path.join(a.out_dir, "unit-phone.png"))
        driver.get(a.url + "#/")
        wait_for(driver, lambda d: tile(d, a.unit), 10)
        overflow = driver.execute_script("return document.documentElement.scrollWidth - window.innerWidth")
        check(overflow <= 1, f"the overview fits a phone's width ({overflow} px too wide)")
        driver.set_window_size(1280, 900)
        drain_console(driver)

        # 4. The leak turns the tile to LEAK (in words, with the reason it is no longer held).
        leak = wait_for(driver, lambda d: tile(d, a.unit).get_attribute("data-leak-state") == "LEAK", a.leak_timeout_s, 0.2)
        if not check(leak is not None, f"the tile turned LEAK within {a.leak_timeout_s} s"):
            return
        figures["leak_after_s"] = round(time.monotonic() - started, 1)
        state = tile(driver, a.unit).find_element(By.CSS_SELECTOR, ".state").text
        check("LEAK" in state, f"LEAK in words: {state!r}")
        label = tile(driver, a.unit).find_element(By.TAG_NAME, "a").get_attribute("aria-label")
        check("LEAK" in label, f"the tile's accessible name says LEAK: {label!r}")
        driver.save_screenshot(os.path.join(a.out_dir, "overview-leak.png"))

        # 5. Kill the daemon: stale within the lease.
        wait_for(driver, lambda d: tile(d, a.unit).get_attribute("data-stale") == "NO", 10)
        check(tile(driver, a.unit).get_attribute("data-stale") == "NO", "live before the kill")
        killed_epoch_ms = time.time() * 1000
        os.kill(a.daemon_pid, signal.SIGKILL)
        killed = time.monotonic()
        stale = wait_for(driver, lambda d: tile(d, a.unit).get_attribute("data-stale") != "NO"
                         and "STALE" in tile(d, a.unit).find_element(By.CSS_SELECTOR, ".stale-note").text,
                         10, 0.02)
        if check(stale is not None, "the tile turned stale after the kill"):
            # When the page drew it (its data-shown-ms, the browser's clock, the same host's), and
            # when this script saw it (plus WebDriver's round trips).
            shown_ms = float(tile(driver, a.unit).get_attribute("data-shown-ms")) - killed_epoch_ms
            seen_ms = (time.monotonic() - killed) * 1000
            stale_ms = shown_ms if 0 <= shown_ms <= seen_ms else seen_ms
            figures["stale_after_kill_ms"] = round(stale_ms)
            figures["stale_seen_by_webdriver_ms"] = round(seen_ms)
            figures["lease_ms"] = round(lease_ms)
            figures["stale_reason"] = tile(driver, a.unit).get_attribute("data-stale")
            check(stale_ms <= lease_ms + 300, f"stale {stale_ms:.0f} ms after the kill; lease {lease_ms:.0f} ms")
        driver.save_screenshot(os.path.join(a.out_dir, "overview-stale.png"))
        drain_console(driver)
    finally:
        # 6. The console, over the whole run.
        try:
            drain_console(driver)
        finally:
            driver.quit()
        errors = [e for e in console if e.get("level") == "SEVERE"]
        check(not errors, f"console errors: {errors}")
        figures["console_entries"] = len(console)
        print(json.dumps(figures), flush=True)


if __name__ == "__main__":
    main()
    sys.exit(1 if failures else 0)
