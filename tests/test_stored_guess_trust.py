"""The stored initial guess is checked before it is believed, and its writer writes only
what it is asked (optimize/solve/starts/stored_guess.py): a damaged, edited or stale file
is named with its reason as a warning before the cold start falls back to the homotopy;
``--record-parts`` with no part, an unknown one or one that makes no OCP exits 2 and
leaves the file as it was."""

from __future__ import annotations

import logging
import shutil

import numpy as np
import pytest
from system_fixtures import system_for

from optimize.solve.starts import stored_guess

LOGGER = "optimize.solve.starts.stored_guess"


def _rewrite(path, change):
    """The file at ``path`` with ``change(arrays)`` applied, its stored hash left as it was
    (what an edit by hand, or a program that knows nothing of the hash, leaves)."""
    with np.load(path) as f:
        arrays = {k: f[k] for k in f.files}
    change(arrays)
    np.savez_compressed(path, **arrays)


def _swap_parts(a):
    a["parts"] = a["parts"][::-1].copy()


def _rename_variable(a):
    a["part_variables"] = np.char.replace(a["part_variables"], "dl_m_s", "dl_x_m_s")


def _perturb(key, at=0, by=1e-3):
    def change(a):
        a[key] = a[key].copy()
        a[key][at] += by
    return change


DAMAGE = {
    # the seven kinds and more of their class
    "part record removed": (lambda a: a.pop("part_variables"), "does not record its parts"),
    "w perturbed": (_perturb("w"), "differs from the SHA-256 it records"),
    "a multiplier perturbed": (_perturb("lam_x", by=1.0), "differs from the SHA-256 it records"),
    "variable renamed": (_rename_variable, "differs from the SHA-256 it records"),
    "parts swapped": (_swap_parts, "differs from the SHA-256 it records"),
    "n_intervals edited": (lambda a: a.update(n_intervals=np.array(20)),
                           "differs from the SHA-256 it records"),
    "system hash edited": (lambda a: a.update(system_sha256=np.array("0" * 64)),
                           "differs from the SHA-256 it records"),
    "scenario renamed": (lambda a: a.update(scenario=np.array("elec-lim-9.0")),
                         "differs from the SHA-256 it records"),
    "hash removed": (lambda a: a.pop(stored_guess.HASH_KEY), "records no content hash"),
    "an array removed": (lambda a: a.pop("lam_g"), "cannot read the stored initial guess"),
}


@pytest.mark.parametrize("case", sorted(DAMAGE))
def test_a_damaged_stored_guess_is_named_before_the_cold_start(case, paper_ocp, tmp_path,
                                                                 caplog):
    path = tmp_path / "guess.npz"
    shutil.copy(stored_guess.GUESS_PATH, path)
    change, why = DAMAGE[case]
    _rewrite(path, change)
    caplog.set_level(logging.WARNING, logger=LOGGER)
    solution, reason = stored_guess.load(paper_ocp, path)
    assert solution is None and why in reason and str(path) in reason, reason
    warnings = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert len(warnings) == 1 and why in warnings[0] and "runs the homotopy" in warnings[0]
    stored_guess.load(paper_ocp, path)  # said once per process, not at every cold start
    assert len([r for r in caplog.records if r.levelno == logging.WARNING]) == 1


@pytest.mark.parametrize("cut", [0, 200, 100_000])
def test_a_truncated_stored_guess_is_named(cut, paper_ocp, tmp_path, caplog):
    path = tmp_path / "cut.npz"
    path.write_bytes(stored_guess.GUESS_PATH.read_bytes()[:cut])
    caplog.set_level(logging.WARNING, logger=LOGGER)
    solution, reason = stored_guess.load(paper_ocp, path)
    assert solution is None and "cannot read the stored initial guess" in reason
    assert any(str(path) in r.getMessage() for r in caplog.records)


def test_the_shipped_guess_is_intact_and_used_without_a_warning(paper_ocp, caplog):
    caplog.set_level(logging.WARNING, logger=LOGGER)
    with np.load(stored_guess.GUESS_PATH) as f:
        assert str(f[stored_guess.HASH_KEY]) == stored_guess.content_sha256(dict(f))
    solution, why = stored_guess.load(paper_ocp)
    assert solution is not None, why
    assert not caplog.records


def test_an_intact_guess_that_no_longer_fits_is_named_as_stale(tmp_path, caplog):
    # written for the paper's kite (at its own start, a circular loop), loaded for one 1 kg
    # heavier: the file is intact, the model it was written for is not this one (as after
    # a change of the kite model without regenerating the file)
    from types import SimpleNamespace

    from optimize.model.kite_model import kite_dae
    from optimize.model.params import KiteParams
    from optimize.paper_model import paper_model
    from optimize.problem.ocp import build_ocp
    from optimize.problem.options import Discretization, OcpOptions
    from optimize.solve.result import Solution
    from optimize.solve.starts.fill import part_start

    small = OcpOptions(Discretization(n_intervals=3, degree=2))
    ocp = build_ocp(kite_dae(), paper_model(), small, system=system_for())
    scenario = stored_guess.GUESS_SCENARIO
    period = float(np.mean(ocp.formulation.period_bounds()))
    a = part_start(ocp, period, scenario.parameters)
    w = ocp.pack(a["x"], a["z"], a["u"], a["fict"], period)
    warm = Solution(w, np.zeros(ocp.layout.n_w), np.zeros(ocp.layout.n_g), 3, 2)
    stored_guess.write(tmp_path / "g.npz", ocp, SimpleNamespace(warm=warm, scenario=scenario),
                       ocp.params(scenario.parameters, scenario.weights))
    assert stored_guess.load(ocp, tmp_path / "g.npz")[0] is not None
    heavier = build_ocp(kite_dae(KiteParams(mass_kg=KiteParams().mass_kg + 1.0)),
                        paper_model(), small, system=system_for())
    caplog.set_level(logging.WARNING, logger=LOGGER)
    solution, why = stored_guess.load(heavier, tmp_path / "g.npz")
    assert solution is None and "does not fit this OCP's constraints" in why
    # both causes named: another drive (a sizing candidate: nothing to regenerate) or
    # changed equations (as here: regenerate)
    assert "sizing candidate" in why and "regenerate it" in why
    assert any("g.npz" in r.getMessage() and "does not fit" in r.getMessage()
               for r in caplog.records if r.levelno == logging.WARNING)


@pytest.mark.parametrize("names, said", [
    ("", "names no part"), (",", "names no part"), ("kite,", "names no part"),
    ("foo", "unknown part foo"), ("kite,lag,wing", "unknown parts lag, wing"),
    ("kite,kite", "a part named twice"),
    # was a TypeError traceback, then "(TypeError: reduce() of empty iterable ...)"
    ("kite", "make no OCP to check the file on (without the part drive the cycle has no "
             "objective"),
])
def test_record_parts_refuses_what_it_was_not_asked_and_leaves_the_file(names, said, tmp_path,
                                                                        capsys):
    path = tmp_path / "t.npz"
    shutil.copy(stored_guess.GUESS_PATH, path)
    before = path.read_bytes()
    # was: '' ran a 128-iteration homotopy and overwrote the file
    assert stored_guess.main(["--out", str(path), "--record-parts", names]) == 2
    err = capsys.readouterr().err
    assert said in err and "Traceback" not in err and "Error" not in err, err
    assert path.read_bytes() == before


def test_the_writer_refuses_an_output_it_cannot_write_before_solving(tmp_path, capsys):
    # a folder as --out: refused at once (exit 2), not after the homotopy's minute
    assert stored_guess.main(["--out", str(tmp_path)]) == 2
    assert "is a folder" in capsys.readouterr().err
    assert stored_guess.main(["--out", str(tmp_path / "none.npz"), "--record-parts",
                              "kite,drive"]) == 2
    assert "no guess file to record the parts of" in capsys.readouterr().err


def test_a_damaged_start_is_named_once_per_run_not_once_per_worker(tmp_path, caplog):
    # was: every worker process that started a chain said it again; now the problem the
    # service ships to the workers is made with the stored guess switched off, said once
    import dataclasses

    from optimize.paper_model import paper_model
    from optimize.problem.options import OcpOptions
    from optimize.service import Problem

    model = paper_model()
    path = tmp_path / "damaged.npz"
    path.write_bytes(stored_guess.GUESS_PATH.read_bytes()[:200])
    options = OcpOptions()
    options = dataclasses.replace(options, solver=dataclasses.replace(
        options.solver, start_file=str(path)))
    caplog.set_level(logging.WARNING, logger=LOGGER)
    first = Problem.for_system(None, model, options)
    again = Problem.for_system(None, model, options)
    assert not first.options.solver.stored_guess and not again.options.solver.stored_guess
    warnings = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert len(warnings) == 1 and str(path) in warnings[0], warnings
    assert "cannot read the stored initial guess" in warnings[0]
    # an intact file leaves the options as they were, without a word
    caplog.clear()
    assert Problem.for_system(None, model, OcpOptions()).options == OcpOptions()
    assert not caplog.records


def test_a_stale_guess_is_named_once_per_run_not_once_per_worker(tmp_path):
    # was: each local worker process that started a chain said it again; the processes
    # of a run (one process group) now say a reason once, whoever finds it first
    import subprocess
    import sys

    code = ("import logging, sys, time\n"
            "logging.basicConfig(level=logging.WARNING, format='%(message)s')\n"
            "from optimize.solve.starts import stored_guess\n"
            "stored_guess._warn(sys.argv[1])\n"
            "time.sleep(3)\n")
    why = f"{tmp_path}/g.npz: the stored initial guess does not fit this OCP's constraints"
    workers = [subprocess.Popen([sys.executable, "-c", code, why], stderr=subprocess.PIPE,
                                text=True) for _ in range(3)]
    err = "".join(p.communicate(timeout=60)[1] for p in workers)
    assert err.count("stored initial guess not used") == 1, err
    assert why in err
    # another run (the processes above gone) says it again
    again = subprocess.run([sys.executable, "-c", code, why], stderr=subprocess.PIPE,
                           text=True, timeout=60, check=True)
    assert again.stderr.count("stored initial guess not used") == 1
