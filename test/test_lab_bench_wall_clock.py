"""``bench wall-clock``: the launch files it runs, the feeder's pacing, and one short real run."""

from __future__ import annotations

import os
import threading
import time

import yaml

from touch_lab.bench.replay import PtyPort, record_scene
from touch_lab.bench.wall_clock import measure, prepared_launch, render, tree_cpu_s, tree_thread_cpu_s
from touch_lab.bench.wall_clock_feed import feed


def test_prepared_launch_sets_read_on_arrival_on_every_driver_and_nothing_else(tmp_path) -> None:
    path = prepared_launch(tmp_path, 'skin_patches.launch.yaml', False)
    nodes = [child['node'] for entry in yaml.safe_load(path.read_text())['launch'] if 'group' in entry
             for child in entry['group']['children']]
    for node in nodes:
        added = [p for p in node['param'] if p['name'] == 'read_on_arrival']
        assert added == ([{'name': 'read_on_arrival', 'value': False}] if node['exec'] == 'skin_driver' else [])
    assert len(nodes) == 16


def test_the_feeder_writes_each_chunk_at_its_time() -> None:
    port = PtyPort()
    try:
        start = time.monotonic()
        out = feed(0.2, [(port.master, 0.02, [b'ab', b'cd'])])
        took = time.monotonic() - start
        assert out['sent'] == [10] and 0.17 <= took < 1.0
        got, deadline = b'', time.monotonic() + 2.0
        while len(got) < 20 and time.monotonic() < deadline:   # the kernel hands pty bytes over a little later
            got += os.read(port._slave, 100) if port.readable() else b''
        assert got == b'abcd' * 5
    finally:
        port.close()


def test_tree_cpu_counts_this_process() -> None:
    before = tree_cpu_s(os.getpid())
    end = time.process_time() + 0.05
    while time.process_time() < end:
        pass
    assert tree_cpu_s(os.getpid()) > before


def test_thread_cpu_is_split_into_the_main_thread_and_the_others() -> None:
    def busy(seconds: float) -> None:
        end = time.thread_time() + seconds
        while time.thread_time() < end:
            pass

    main0, other0 = tree_thread_cpu_s(os.getpid())
    worker = threading.Thread(target=busy, args=(0.3,))
    worker.start()
    worker.join()
    main1, other1 = tree_thread_cpu_s(os.getpid())
    busy(0.3)
    main2, other2 = tree_thread_cpu_s(os.getpid())
    assert other1 - other0 >= 0.2 and main1 - main0 < 0.1      # clock ticks: 0.01 s
    assert main2 - main1 >= 0.2 and other2 - other1 < 0.1


def test_one_patch_launched_on_the_wall_clock_publishes_every_frame_sent() -> None:
    recordings = {'skin': record_scene('skin', 4.0)}
    run = measure('patches', 1, 1.0, True, False, recordings)
    assert run['all_published'] and run['frames_missed'] == 0
    assert run['frames_sent'] >= 300                      # 3.5 s fed at 150 Hz
    assert run['percent_of_core'] > 0
    assert abs(run['main_threads_percent'] + run['other_threads_percent'] - run['percent_of_core']) < 5


def test_the_report_renders_every_configuration() -> None:
    row = {'percent_of_core': 1.5, 'runs_percent': [1.5], 'frames_sent': 10, 'frames_published': 10,
           'no_frame_missed': True, 'load_average_1min': 3.0}
    figures = {'seconds': 5.0, 'repeats': 1, 'cpu_count': 2, 'goals': {'sensors_percent': 3.0,
                                                                       'per_extra_patch_percent': 1.0},
               'sensors': {'arrival': row}, 'patches': {'arrival': {1: row, 2: row, 'per_extra_patch': 0.0}},
               'patches_processes': {}}
    text = render(figures, 'wall-clock.png')
    assert '| arrival | 1.50 |' in text and '| one | arrival | 2 | 1.50 |' in text
    assert '- one process, arrival: 0.00' in text and '![CPU against N patches](wall-clock.png)' in text
