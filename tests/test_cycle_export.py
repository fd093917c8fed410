"""``bench cycle export``: the profile's energy against the closed form, the bench's frame
and limits, the file's reader against its writer, and bad input refused."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from bench.cycle_profile import BenchFrame, plain_paths, read_profile, window_integral
from cycle.export import ExportOptions, export_cycle
from drivebench.cli import main
from kernel.errors import InputError
from kernel.units import RPM_PER_RAD_S
from tests.cycle_fixtures import exact_e_mech_j, write_cycle_sweep


@pytest.fixture(scope="module")
def sweep(tmp_path_factory):
    folder = tmp_path_factory.mktemp("cycle") / "opt"
    write_cycle_sweep(folder)
    return folder


def test_profile_energy_matches_the_closed_form(sweep, tmp_path):
    """Each cycle's integral of speed x torque, read back from the file, is the closed
    form's within 0.05 % (issue tolerance 0.5 %; PCHIP on 160 points and the file's
    rounding to 0.001 rpm and 0.0001 N m leave about 0.01 %)."""
    out = tmp_path / "p.csv"
    done = export_cycle(sweep, "elec-lim-7.0", out, ExportOptions(n_cycles=4, rate_hz=200.0))
    p = read_profile(out)
    speed, torque = p.drum()
    t0, period = p.header["cycle_start_s"], p.period_s
    exact = exact_e_mech_j("elec-lim-7.0")
    for k in range(4):
        e = window_integral(p.columns["time_s"], speed * torque / RPM_PER_RAD_S,
                            t0 + k * period, t0 + (k + 1) * period)
        assert e == pytest.approx(exact, rel=5e-4)
    assert done.e_mech_error < 5e-4
    # within the limits, from standstill to standstill, the tare first
    assert np.abs(speed).max() <= 1500.0 and torque.max() <= 78.0 and torque.min() >= 0.0
    assert speed[0] == speed[-1] == torque[0] == torque[-1] == 0.0
    assert np.all(speed[p.columns["time_s"] < 10.0] == 0.0)
    assert p.n_cycles == 4 and set(np.unique(p.columns["cycle"])) == {-1, 0, 1, 2, 3}


def test_bench_frame_and_plain_tables(sweep, tmp_path):
    """Motor side, gear 3, speed logged with the opposite sign: the set-points are the
    drum's carried into that frame, and the reader carries them back."""
    frame = BenchFrame("motor", 3.0, -1, 1)
    out = tmp_path / "m.csv"
    export_cycle(sweep, "elec-lim-7.0", out, ExportOptions(n_cycles=2, frame=frame))
    drum = export_cycle(sweep, "elec-lim-7.0", tmp_path / "d.csv", ExportOptions(n_cycles=2))
    p = read_profile(out)
    assert p.frame == frame
    np.testing.assert_allclose(p.columns["speed_set_rpm"],
                               -3.0 * drum.profile.columns["speed_set_rpm"], atol=2e-3)
    np.testing.assert_allclose(p.drum()[1], drum.profile.columns["torque_set_nm"], atol=1e-3)
    tables = plain_paths(out)
    speed = np.loadtxt(tables["speed"], delimiter=",")
    assert speed.shape == (p.columns["time_s"].size, 2)
    np.testing.assert_allclose(speed[:, 1], p.columns["speed_set_rpm"], atol=1e-3)


def test_outside_the_rating_is_refused_saying_where(sweep, tmp_path, capsys):
    rc = main(["cycle", "export", "--optimize", str(sweep), "--scenario", "elec-free-9.0",
               "--out", str(tmp_path / "x.csv")])
    err = capsys.readouterr().err
    assert rc == 2 and "leaves the bench's rating" in err and "|speed| 1700.0 rpm" in err
    assert "max_speed_rpm" in err and not (tmp_path / "x.csv").exists()


def test_bad_scenario_and_out_refused(sweep, tmp_path, capsys):
    assert main(["cycle", "export", "--optimize", str(sweep), "--scenario", "elec-lim-3.0",
                 "--out", str(tmp_path / "x.csv")]) == 2
    assert "not in the sweep" in capsys.readouterr().err
    other = tmp_path / "notes.csv"
    other.write_text("mine\n")
    assert main(["cycle", "export", "--optimize", str(sweep), "--scenario", "elec-lim-7.0",
                 "--out", str(other)]) == 2
    assert other.read_text() == "mine\n"


def test_reader_names_the_problem(sweep, tmp_path):
    out = tmp_path / "p.csv"
    export_cycle(sweep, "elec-lim-7.0", out, ExportOptions(n_cycles=1))
    text = out.read_text()
    (tmp_path / "a.csv").write_text(text.replace("# period_s", "# periods"))
    with pytest.raises(InputError, match="period_s"):
        read_profile(tmp_path / "a.csv")
    lines = text.splitlines()
    lines[-5] = "1.0,nan,2,3,4,0"
    (tmp_path / "b.csv").write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError, match=f"b.csv:{len(lines) - 4}:"):
        read_profile(tmp_path / "b.csv")


def test_bench_session_limits_and_bad_options(sweep, tmp_path):
    """A bench session whose torque flange is too small for the cycle refuses it, naming
    its [sensors] key; options out of range are refused naming the option."""
    session = tmp_path / "small"
    session.mkdir()
    (session / "session.toml").write_text(
        'session_id = "small"\nkind = "timeseries"\nmode = "motor"\ngear_ratio = 3.0\n'
        'measured_side = "motor"\nspeed_sign = 1\ntorque_sign = 1\n'
        '[daq]\nfile = "daq.csv"\n[analyzer]\nfile = "analyzer.csv"\n'
        '[sensors]\ntorque_range_nm = 20.0\n')  # 60 N m at the drum: the cycle needs 70
    with pytest.raises(InputError, match=r"torque_range_nm \(at the drum\)"):
        export_cycle(sweep, "elec-lim-7.0", tmp_path / "p.csv", bench_session=session)
    for bad in ({"n_cycles": 0}, {"rate_hz": 0.5}, {"standstill_s": 1.0}):
        with pytest.raises(InputError, match="--"):
            ExportOptions(**bad)


def test_period_and_phase_are_found(sweep, tmp_path):
    """A log on a clock 300 ppm slow, starting 7.3 s before the profile: cut_cycles finds
    that phase and that period (to 0.1 ms), not the profile's."""
    from bench.ingest.cycles import cut_cycles

    export_cycle(sweep, "elec-lim-7.0", tmp_path / "p.csv", ExportOptions(n_cycles=6))
    p = read_profile(tmp_path / "p.csv")
    speed, torque = p.drum()
    scale, lead = 1.0 + 300e-6, 7.3
    t_bins = np.arange(0.05, lead + p.columns["time_s"][-1] * scale + 2.0, 0.1)
    t_prof = (t_bins - lead) / scale  # the profile's time at each bin
    bins = {"t": t_bins,
            "speed": np.interp(t_prof, p.columns["time_s"], speed, left=0.0, right=0.0),
            "torque": np.interp(t_prof, p.columns["time_s"], torque, left=0.0, right=0.0),
            "p_elec": np.full(t_bins.size, 100.0), "recorded": np.ones(t_bins.size, bool),
            "gap": np.zeros(t_bins.size, bool)}
    where = {k: tmp_path / k for k in ("session", "profile", "daq")}
    cut = cut_cycles(bins, p, where)
    assert cut.period_s == pytest.approx(p.period_s * scale, abs=1e-4)
    assert cut.phase_s == pytest.approx(lead + p.header["cycle_start_s"] * scale, abs=1e-3)
    assert cut.kept == [1, 2, 3, 4, 5] and cut.rejected == {0: "cycle settling"}


def test_plain_tables_replace_only_what_an_export_wrote(sweep, tmp_path, capsys):
    """The header names the two tables with their hashes: an earlier export's are replaced;
    a user's own ``run.speed.csv``, a table edited since, or a folder in a table's place is
    refused (exit 2, naming it), every file as it was."""
    out = tmp_path / "run.csv"
    tables = plain_paths(out)
    argv = ["cycle", "export", "--optimize", str(sweep), "--scenario", "elec-lim-7.0",
            "--cycles", "1", "--out", str(out)]
    tables["speed"].write_text("my own speed table\n")
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "run.speed.csv: option --out: exists and was not written by an earlier" in err
    assert tables["speed"].read_text() == "my own speed table\n" and not out.exists()
    assert not tables["torque"].exists()
    tables["speed"].unlink()
    assert main(argv) == 0
    header = read_profile(out).header
    assert header["speed_table"] == "run.speed.csv" and header["torque_table"] == "run.torque.csv"
    assert main([*argv[:-3], "2", "--out", str(out)]) == 0  # an export's own: replaced
    assert read_profile(out).n_cycles == 2
    edited = tables["torque"].read_text().replace("0.0000", "0.0001", 1)
    tables["torque"].write_text(edited)
    assert main(argv) == 2
    assert "was changed since the export that wrote it" in capsys.readouterr().err
    assert tables["torque"].read_text() == edited and read_profile(out).n_cycles == 2
    tables["torque"].unlink()
    tables["torque"].mkdir()
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "run.torque.csv: option --out" in err and "Traceback" not in err


def test_two_exports_to_one_profile_serialize(sweep, tmp_path):
    """Two exports of different scenarios to the same --out at once: one waits for the
    other, and the profile and both tables are one export's (their hashes in its header)."""
    from kernel.files import file_sha256

    out = tmp_path / "p.csv"
    code = ("import sys; from pathlib import Path; from cycle.export import ExportOptions, "
            "export_cycle\nexport_cycle(Path(sys.argv[1]), sys.argv[2], Path(sys.argv[3]), "
            "ExportOptions(n_cycles=3))\n")
    cwd = Path(__file__).resolve().parents[1]
    procs = [subprocess.Popen([sys.executable, "-c", code, str(sweep), s, str(out)], cwd=cwd,
                              stderr=subprocess.PIPE, text=True)
             for s in ("elec-lim-7.0", "elec-lim-5.5")]
    assert [p.wait() for p in procs] == [0, 0], [p.stderr.read() for p in procs]
    header = read_profile(out).header
    for q, path in plain_paths(out).items():
        assert header[f"{q}_table_sha256"] == file_sha256(path)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.csv", "p.speed.csv",
                                                         "p.torque.csv"]


def test_an_export_waits_for_one_in_mid_write_before_it_checks_the_tables(sweep, tmp_path):
    """An export that starts while another has replaced the tables but not yet the profile
    naming them waits for that one to finish (it does not refuse the tables as a user's
    own), then replaces all three."""
    from bench.cycle_profile import write_profile
    from kernel.files import file_sha256
    from kernel.locking import output_lock

    out = tmp_path / "p.csv"
    first = export_cycle(sweep, "elec-lim-7.0", out, ExportOptions(n_cycles=3))
    speed = plain_paths(out)["speed"]
    code = ("import sys; from pathlib import Path; from cycle.export import ExportOptions, "
            "export_cycle\nexport_cycle(Path(sys.argv[1]), 'elec-lim-5.5', Path(sys.argv[2]), "
            "ExportOptions(n_cycles=3))\n")
    with output_lock(out, "cycle export"):  # the other export, in mid-write
        speed.write_text(speed.read_text() + "0.0,0.0\n")  # no profile names it yet
        proc = subprocess.Popen([sys.executable, "-c", code, str(sweep), str(out)],
                                cwd=Path(__file__).resolve().parents[1],
                                stderr=subprocess.PIPE, text=True)
        line = proc.stderr.readline()  # it waits for the lock before any check
        assert "waiting for another process" in line, line + proc.stderr.read()
        write_profile(out, first.profile)  # the other export's tables and profile
    assert proc.wait(timeout=300) == 0, proc.stderr.read()
    header = read_profile(out).header
    assert header["scenario"] == "elec-lim-5.5"
    for q, path in plain_paths(out).items():
        assert header[f"{q}_table_sha256"] == file_sha256(path)


def test_a_folder_without_the_drive_in_force_is_refused_naming_its_manifest(tmp_path):
    # an older bench optimize recorded the drive as drive_limits: its limits are not read
    # as none (a cycle exported unchecked), the folder is refused with the remedy
    from cycle.export import flown_drive
    from kernel.errors import InputError

    with pytest.raises(InputError) as err:
        flown_drive({"drive_limits": {"max_torque_nm": 78.0}}, tmp_path)
    text = err.value.describe()
    assert str(tmp_path / "manifest.json") in text and "re-run `bench optimize`" in text
    assert flown_drive({"sections": {"drive": {"max_torque_nm": 78.0}}}, tmp_path).box() == (
        None, 78.0)
    with pytest.raises(InputError, match="sections.drive: unknown key 'torque_nm'"):
        flown_drive({"sections": {"drive": {"torque_nm": 78.0}}}, tmp_path)
