"""trimd as a user installs it: a wheel built from the checkout, installed into a fresh
virtualenv outside it, runs ``trimd demo`` and ``trimd solve`` with the shipped profiles
(package data) and nothing from the source tree.

The virtualenv is made without pip of its own; the test's pip (``pip --python``) installs
the wheel alone, and the dependencies come from the test's own environment, through a
``.pth`` line naming its site-packages (``make install`` installed them from the same
``pyproject.toml``). A path added so is searched after the virtualenv's own
site-packages and its ``.pth`` files are not read, so the checkout's editable install of
trimd is not seen: ``trimd`` is the wheel's (asserted)."""

from __future__ import annotations

import os
import subprocess
import sys
import sysconfig
import zipfile
from pathlib import Path

import pytest

from tests.helpers import REPO


def _run(args: list[str | Path], cwd: Path, timeout: float = 600.0) -> str:
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    proc = subprocess.run([str(a) for a in args], cwd=cwd, env=env, capture_output=True,
                          text=True, timeout=timeout)
    assert proc.returncode == 0, f"{args}\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}"
    return proc.stdout


def _extra_mass_kg(report: str) -> float:
    """m_ext [kg] from the estimate's table ("extra mass m_ext   9.987 ± 0.037 kg")."""
    line = next(line for line in report.splitlines() if line.startswith("extra mass m_ext"))
    return float(line.split()[3])


@pytest.mark.slow
def test_the_wheel_runs_outside_the_checkout(tmp_path: Path) -> None:
    dist, venv, work = tmp_path / "dist", tmp_path / "venv", tmp_path / "work"
    work.mkdir()
    _run([sys.executable, "-m", "pip", "wheel", "--quiet", "--no-deps", "-w", dist, REPO],
         cwd=work)
    (wheel,) = dist.glob("trimd-*.whl")
    page = {f"trimd/app/web/static/{f}" for f in ("index.html", "app.js", "style.css")}
    assert page <= set(zipfile.ZipFile(wheel).namelist())   # trimd serve's page
    _run([sys.executable, "-m", "venv", "--without-pip", venv], cwd=work)
    python = venv / "bin" / "python"
    site = _run([python, "-c", "import sysconfig; print(sysconfig.get_path('purelib'))"],
                cwd=work).strip()
    (Path(site) / "deps.pth").write_text(sysconfig.get_path("purelib") + "\n")
    _run([sys.executable, "-m", "pip", "--python", python, "install", "--quiet", "--no-compile",
          "--no-deps", wheel], cwd=work)
    where = _run([python, "-c", "import trimd; print(trimd.__file__)"], cwd=work).strip()
    assert Path(where).is_relative_to(venv), where

    demo = _run([venv / "bin" / "trimd", "demo"], cwd=work)
    assert "simulator truth: payload 10@AftSB" in demo, demo
    assert abs(_extra_mass_kg(demo) - 10.0) < 0.2, demo

    holds = work / "holds.csv"
    _run([sys.executable, REPO / "examples" / "make_holds.py", "sabertooth-dh2", "10@AftSB",
          holds], cwd=work)
    solved = _run([venv / "bin" / "trimd", "solve", holds, "--profile", "sabertooth-dh2"],
                  cwd=work)
    assert abs(_extra_mass_kg(solved) - 10.0) < 0.1, solved
