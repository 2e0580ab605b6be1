"""The touch view in a real browser: headless Chromium (Selenium) watches a scripted scene live.

The scene (written here, SYNTHETIC): the bear's virtual device plays a hug, the skin's a line
traced left to right; the patch is not in the scene. The page must show the hug and the skin's
command (the gesture the scene performed), only the two sensors the scene runs, and a sensor
whose driver goes away as SILENT.
"""

from __future__ import annotations

import pytest
from selenium.webdriver.support.ui import WebDriverWait

from touch_view.browser import headless_chromium

HUG = '[chest_left, back_upper, back_middle, side_left_upper, side_right_lower]'


@pytest.fixture
def start_scene(scene_launch, run_scene):
    """Start the scene when called: after the browser, whose start on a busy machine takes seconds
    that the scene's clock would otherwise spend (the hug lasts as long as the skin's scene, so the
    page sees it under way however late it loads)."""
    return lambda: run_scene(scene_launch(
        bear=[f'{{sensors: {HUG}, start: 4.0, duration: 26.0, level: 1.0}}'],
        skin=['line: {from_mm: [6, 23], to_mm: [41, 23], at_s: 3.0, for_s: 0.8, force_n: 1.5}'],
        serve=['touch_view']))


def text_of(browser, css):
    """The text of the element at ``css`` (read in one script: the page redraws 20 times a second)."""
    return browser.execute_script('const e = document.querySelector(arguments[0]); return e ? e.innerText : null;', css)


def attribute(browser, css, name):
    return browser.execute_script('const e = document.querySelector(arguments[0]); '
                                  'return e ? e.getAttribute(arguments[1]) : null;', css, name)


def count(browser, css):
    return browser.execute_script('return document.querySelectorAll(arguments[0]).length;', css)


def test_the_page_shows_the_scene_live_in_a_real_browser(start_scene, tmp_path):
    with headless_chromium(1400, 1000) as browser:
        scene = start_scene()
        browser.get(scene.node('touch_view').url)
        wait = WebDriverWait(browser, 30, poll_frequency=0.2)
        wait.until(lambda b: int(attribute(b, 'body', 'data-frames')) > 3)
        # Only the sensors of the scene: the bear and the skin, not the patch.
        wait.until(lambda b: attribute(b, '#sensor-bear', 'data-state') == 'live')
        assert attribute(browser, '#sensor-skin', 'data-state') == 'live'
        assert attribute(browser, '#bear-card', 'hidden') is None
        assert attribute(browser, '#patch-card', 'hidden') is not None
        assert count(browser, '#sensor-patch') == 0
        # The skin's command: the line left to right is 'line_right' -> 'move_right' (config/skin_commands.yaml).
        wait.until(lambda b: attribute(b, '#skin-command', 'data-command') == 'move_right')
        assert text_of(browser, '#skin-command-gesture') == 'line_right'
        assert float(text_of(browser, '#skin-command-margin')) > 0
        # The bear's hug, with its regions highlighted on the outline and live levels on the sensors.
        wait.until(lambda b: count(b, '#bear-gestures li[data-gesture="hug"]') == 1)
        highlighted = set(browser.execute_script(
            "return [...document.querySelectorAll('.body.hl')].map(e => e.getAttribute('data-region'));"))
        assert {'torso_back', 'torso_front', 'side_left', 'side_right'} <= highlighted
        assert count(browser, '#bear-svg .sensor.active') >= 4
        assert 'hug started' in text_of(browser, '#log')
        assert "command 'move_right'" in text_of(browser, '#log')
        drivers = text_of(browser, '#drivers')
        assert '/bear/bear_driver' in drivers and '/skin/skin_driver' in drivers
        browser.save_screenshot(str(tmp_path / 'touch-view.png'))
        assert (tmp_path / 'touch-view.png').stat().st_size > 10_000

        # The skin's driver goes away: the page says the skin is SILENT (stale after 1 s by default).
        scene.call_in_graph(scene.node('skin_driver').destroy_node)
        wait.until(lambda b: attribute(b, '#sensor-skin', 'data-state') == 'silent')
        assert 'SILENT' in text_of(browser, '#skin-card .silent-banner')
        assert attribute(browser, '#sensor-bear', 'data-state') == 'live'
        assert [e for e in browser.get_log('browser') if e['level'] == 'SEVERE'] == []  # no script error


def test_the_page_shows_a_collect_sessions_prompt_only_while_one_is_published(scene_launch, run_scene):
    from touch_graph.compat import DurabilityPolicy, QoSProfile, get_message
    from touch_lab.collect.live import PROMPT_TOPIC
    scene = run_scene(scene_launch(
        skin=['line: {from_mm: [6, 23], to_mm: [41, 23], at_s: 3.0, for_s: 0.8, force_n: 1.5}'], serve=['touch_view']))
    view = scene.node('touch_view')
    string = get_message('std_msgs/msg/String')
    # The collect session's publisher, latched as live.py makes it, on the scene's context.
    latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    prompts = view.create_publisher(string, PROMPT_TOPIC, latched)
    with headless_chromium(1000, 800) as browser:
        browser.get(view.url)
        wait = WebDriverWait(browser, 30, poll_frequency=0.2)
        wait.until(lambda b: int(attribute(b, 'body', 'data-frames')) > 3)
        assert attribute(browser, '#collect-prompt', 'hidden') is not None   # no session: no panel
        prompts.publish(string(data='trial 3/24: pat (gentle): press Enter, perform it, press Enter when done'))
        wait.until(lambda b: attribute(b, '#collect-prompt', 'hidden') is None)
        assert text_of(browser, '#collect-prompt') == ('collect: trial 3/24: pat (gentle): press Enter, perform it, '
                                                       'press Enter when done')
        prompts.publish(string(data=''))   # the session ended
        wait.until(lambda b: attribute(b, '#collect-prompt', 'hidden') is not None)
