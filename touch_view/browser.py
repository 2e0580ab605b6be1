"""A headless Chromium driven by Selenium, for the view's browser test and its screenshot command.

Uses the system's ``chromium`` and ``chromedriver`` (Debian packages ``chromium`` and
``chromium-driver``), never a browser downloaded at run time: Selenium is given both paths,
so its driver manager does not go online. The flags keep Chromium off the network (no
component updates, sync or background requests) and give it a fresh profile, so it starts
the same on a closed machine.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from collections.abc import Iterator
from typing import Any

from .errors import ViewError

__all__ = ['CHROMEDRIVER', 'CHROMIUM', 'FLAGS', 'headless_chromium']

CHROMIUM = os.environ.get('SOCIAL_TOUCH_CHROMIUM', '/usr/bin/chromium')
CHROMEDRIVER = os.environ.get('SOCIAL_TOUCH_CHROMEDRIVER', '/usr/bin/chromedriver')
FLAGS = ('--headless', '--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
         '--disable-background-networking', '--disable-component-update', '--disable-sync',
         '--disable-dev-shm-usage', '--hide-scrollbars')


@contextlib.contextmanager
def headless_chromium(width: int = 1400, height: int = 1000) -> Iterator[Any]:
    """A Selenium ``webdriver.Chrome`` on headless Chromium, quit and its profile removed afterwards.

    Raises:
        ViewError: when selenium, chromium or chromedriver is missing (with how to install them).
    """
    try:  # optional: selenium is a test dependency, missing is a ViewError below
        from selenium import webdriver
        from selenium.webdriver.chrome.service import Service
    except ImportError as err:
        raise ViewError("selenium is not installed: pip install -e '.[test]'") from err
    for path, package in ((CHROMIUM, 'chromium'), (CHROMEDRIVER, 'chromium-driver')):
        if not os.access(path, os.X_OK):
            raise ViewError(f'{path} is missing: apt-get install -y {package} (or set SOCIAL_TOUCH_CHROMIUM / '
                            'SOCIAL_TOUCH_CHROMEDRIVER to another build)')
    profile = tempfile.mkdtemp(prefix='touch_view-chromium-')
    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for flag in (*FLAGS, f'--user-data-dir={profile}', f'--window-size={width},{height}'):
        options.add_argument(flag)
    driver = None
    try:
        driver = webdriver.Chrome(options=options, service=Service(executable_path=CHROMEDRIVER))
        yield driver
    finally:
        if driver is not None:
            driver.quit()
        shutil.rmtree(profile, ignore_errors=True)
