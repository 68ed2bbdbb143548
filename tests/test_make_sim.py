"""`make sim MODEL=...` as the README and docs/plant_files.md write it, for every shipped plant.

A relative ``--work`` once sent the simulators, which run in another folder, looking for their
vectors in the wrong place (issue 21): every shipped plant file's command must expand to an
absolute work folder, and one runs for real through make, from the repository's top, on Icarus
(a few cocotb tests of the core suite: the path from make to the simulator's vectors is the
point; tests/test_sim*.py run the regressions themselves).
"""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
PLANT_FILES = [p for p in sorted((REPO / "models").glob("*.toml"))
               if not re.search(r"^extends\s*=", p.read_text(encoding="utf-8"), re.M)]


def make(*args, timeout=900) -> subprocess.CompletedProcess:
    return subprocess.run(["make", *args], cwd=REPO, capture_output=True, text=True, timeout=timeout)


def test_the_documents_write_make_sim_with_a_model():
    readme = (REPO / "README.md").read_text(encoding="utf-8")
    plant_files = (REPO / "docs" / "plant_files.md").read_text(encoding="utf-8")
    assert "make sim MODEL=" in readme and "make sim MODEL=" in plant_files
    assert len(PLANT_FILES) >= 2


@pytest.mark.parametrize("plant", PLANT_FILES, ids=[p.stem for p in PLANT_FILES])
def test_make_sim_gives_the_simulators_an_absolute_work_folder(plant):
    if shutil.which("make") is None:
        pytest.skip("no make")
    done = make("-n", "sim", f"MODEL=models/{plant.name}")
    assert done.returncode == 0, done.stderr
    line = next(x for x in done.stdout.splitlines() if "tb/run.py" in x)
    work = re.search(r"--work (\S+)", line).group(1)
    assert f"--model models/{plant.name}" in line and Path(work).is_absolute()
    assert Path(work) == REPO / "sim_build" / plant.stem


def test_make_sim_runs_as_written_on_a_second_plant():
    if shutil.which("make") is None or shutil.which("iverilog") is None:
        pytest.skip("no make or no Icarus")
    plant = "models/furuta_qube.toml"
    done = make("sim", f"MODEL={plant}", "SIM=icarus", "TB_ARGS=--suite core -k reset_state,step_handshake")
    assert done.returncode == 0, (done.stdout + done.stderr)[-2000:]
    assert re.search(r"\[icarus\] core: 2/2 passed", done.stdout), done.stdout[-2000:]
    assert (REPO / "sim_build" / "furuta_qube" / "vectors.pickle").is_file()
