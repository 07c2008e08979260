"""``python -m warehouse_phys.train --eval``: a saved table evaluated on its own floor."""

from tests.apps.test_train import run_cli
from warehouse_phys import train as train_cli


def test_eval_uses_the_tables_grid_and_refuses_another(tmp_path):
    # No GIF: what is checked is the table (the GIFs are test_train.py's).
    assert train_cli.main(
        ["--env", "grid", "--rows", "3", "--cols", "4", "--episodes", "400", "--quiet",
         "--no-gif", "--out", str(tmp_path / "run")]
    ) == 0  # fmt: skip
    table = tmp_path / "run" / "qtable.npz"
    ok = run_cli("--eval", "run/qtable.npz", cwd=tmp_path)
    assert ok.returncode == 0, ok.stderr
    lines = ok.stdout.splitlines()
    # The file as given, and the table's own environment, floor and training.
    assert lines[0].startswith(
        "evaluating run/qtable.npz (warehouse-robot-v0, 3x4, 400 episodes, seed 0)"
    )
    assert "all 6 targets reached by a shortest path" in lines
    # The same table drives the physics-backed robot just as well.
    phys = run_cli("--eval", str(table), "--env", "phys", cwd=tmp_path)
    assert phys.returncode == 0, phys.stderr
    assert "on warehouse-robot-phys-v0" in phys.stdout
    assert "all 6 targets reached by a shortest path" in phys.stdout
    wrong = run_cli("--eval", str(table), "--rows", "4", "--cols", "5", cwd=tmp_path)
    assert wrong.returncode == 2
    assert wrong.stderr.splitlines() == [
        f"python -m warehouse_phys.train: error: --eval: {table} holds a table for a "
        "3x4 grid, not 4x5"
    ]
