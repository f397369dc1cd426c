"""Retakes the README's picture of the web client (docs/images/client-liquid.png).

With ``srg serve`` running on the demo's database::

    python docs/results/client-screenshot/screenshot.py \
        http://127.0.0.1:8000/?graph=demo.sr-crowd.0 docs/images/client-liquid.png

The page is opened at 1280 x 800 in Debian's headless Chromium, played for a few
seconds with the left arrow held (the tank tilted, the water splashing), then taken. A
third argument names another key to hold (``ArrowRight``), or ``none`` to take the
tank at rest.
"""

from __future__ import annotations

import sys

from playwright.sync_api import sync_playwright

URL, OUT = sys.argv[1], sys.argv[2]
KEY = sys.argv[3] if len(sys.argv) > 3 else "ArrowLeft"

with sync_playwright() as p:
    browser = p.chromium.launch(
        executable_path="/usr/bin/chromium", args=["--headless", "--no-sandbox", "--disable-gpu"]
    )
    page = browser.new_page(viewport={"width": 1280, "height": 800})
    page.goto(URL)
    page.wait_for_timeout(3000)
    if KEY != "none":
        page.keyboard.down(KEY)
    page.wait_for_timeout(1600)
    page.screenshot(path=OUT)
    if KEY != "none":
        page.keyboard.up(KEY)
    browser.close()
