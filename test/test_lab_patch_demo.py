"""The patch demo: gestures and panel contact reported frame by frame as they happen (SYNTHETIC)."""

from touch_lab.patch.demo import main, play, train_simulated
from touch_sim.patch.people import demo_scene


def test_demo_reports_gestures_and_handling(capsys):
    model = train_simulated(people=2, events=2, chain='simple', n_components=1)
    scene = demo_scene(seed=3, n_events=4)
    lines = list(play(model, scene, chain='simple'))
    gestures = [line for line in lines if line.kind == 'gesture']
    assert gestures and all(line.text.split()[0] in model.classes for line in gestures)
    assert [line.time_s for line in lines] == sorted(line.time_s for line in lines)
    for line in gestures:  # reported while or shortly after something touched the patch
        assert any(e.onset_s <= line.time_s <= e.offset_s + 3.0 for e in scene.events)
    kinds = {line.kind for line in lines}
    if scene.panel_contacts():
        assert {'handled', 'released'} <= kinds


def test_demo_main_with_a_model_file(tmp_path, capsys):
    from touch_gestures.patch.model_io import save_model
    path = tmp_path / 'm.npz'
    save_model(path, train_simulated(people=2, events=1, chain='simple', n_components=1))
    assert main(['--model', str(path), '--events', '2', '--chain', 'simple']) == 0
    assert 'SYNTHETIC demo scene' in capsys.readouterr().out
