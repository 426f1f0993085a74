"""formation_rl.apps.render: the GIF and Figure 10, and its step check."""

from helpers import run_module as _cli


def test_render_cli_writes_gif_and_figure_10(trained, tmp_path):
    out = _cli("formation_rl.apps.render", f"ckpt={trained}", "steps=[2,10,19]", f"out={tmp_path}")
    assert out.returncode == 0, out.stderr[-2000:]
    assert (tmp_path / "trajectories.png").stat().st_size > 10_000 and (tmp_path / "episode.gif").exists()
    out = _cli("formation_rl.apps.render", f"ckpt={trained}", "steps=[500]", f"out={tmp_path}")
    assert out.returncode == 2 and "steps = [500] is invalid" in out.stderr
