"""Headless Chromium for the browser tests: the system's binary (installed with apt-get when missing) driven by
Playwright, one page with its JavaScript errors collected."""

from __future__ import annotations

import shutil
import subprocess
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import pytest

from .conftest import CI

CHROMIUM = "/usr/bin/chromium"
ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking"]


def chromium_path() -> str:
    """Path of the system Chromium, installing it with apt-get if absent (a failure under CI, else a skip)."""
    if not Path(CHROMIUM).exists() and shutil.which("apt-get"):
        # a fresh machine may have no package lists yet: update once, then install
        subprocess.run(["apt-get", "update"], capture_output=True, timeout=600)
        subprocess.run(["apt-get", "install", "-y", "chromium"], capture_output=True, timeout=900)
    if not Path(CHROMIUM).exists():
        if CI:
            pytest.fail("Chromium is not installed at /usr/bin/chromium")
        pytest.skip("Chromium is not installed at /usr/bin/chromium")
    return CHROMIUM


@contextmanager
def chromium_page(**page_options: Any) -> Iterator[tuple[Any, Any, list[str]]]:
    """(browser, page, errors): a headless Chromium, a new page (``page_options``: e.g. viewport) and the list its
    uncaught JavaScript errors are appended to; the browser is closed on exit."""
    from playwright.sync_api import sync_playwright

    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=chromium_path(), headless=True, args=ARGS)
        try:
            page = browser.new_page(**page_options)
            errors: list[str] = []
            page.on("pageerror", lambda exc: errors.append(str(exc)))
            yield browser, page, errors
        finally:
            browser.close()
