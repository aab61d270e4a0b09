"""No data loss (hpctl.data.output): outputs staged and renamed into place,
a manifest of what hpctl wrote, stale outputs removed, one run per folder,
records written as a pair; a full disk and Ctrl-C leave the previous
outputs as they were."""

from __future__ import annotations

import errno
import json
import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from hpctl.cli import main
from hpctl.data import output
from hpctl.data.output import LOCK, MANIFEST, OutputDir, reading
from hpctl.data.records import RecordStatic, RecordTest, RecordUnit, RigRecord, read_record, record_paths, write_record
from hpctl.errors import OutputError, RecordError


def snapshot(folder: Path) -> dict[str, bytes]:
    """Every file under ``folder`` (hidden ones included) with its bytes."""
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def visible(folder: Path) -> dict[str, bytes]:
    return {k: v for k, v in snapshot(folder).items() if not k.startswith(".")}


def record(n: int = 5, offset: float = 0.0) -> RigRecord:
    t = np.arange(n, dtype=float)
    return RigRecord(
        kind="characterisation", unit=RecordUnit(2e-3, 0.3e-3, 0.7e-3), static=RecordStatic(1.48e7, 293.15, 293.15),
        test=RecordTest("hard", "off", "sine", 0.02, 0.1), data={"time_s": t, "disp_m": 0.01 * t + offset, "force_n": 1e3 * t}, name="r",
    )


def cli(*args: str) -> tuple[int, str]:
    r = CliRunner().invoke(main, list(args))
    return r.exit_code, r.stderr


# ------------------------------------------------------------- the writer


def test_outputs_appear_only_when_the_run_ends(tmp_path: Path) -> None:
    with OutputDir(tmp_path, "test") as out:
        out.write_text("a.txt", "one")
        write_record(record(), out.path("records/r"))
        assert visible(tmp_path) == {}  # nothing in place yet
    assert set(visible(tmp_path)) == {"a.txt", "records/r.csv", "records/r.toml"}
    assert not list(tmp_path.glob(".hpctl-staging-*")) and not (tmp_path / LOCK).exists()
    files = json.loads((tmp_path / MANIFEST).read_text())["files"]
    assert set(files) == {"a.txt", "records/r.csv", "records/r.toml"}
    assert files["a.txt"]["sha256"] == output.sha256_file(tmp_path / "a.txt") and files["a.txt"]["command"] == "test"


def test_a_failed_run_leaves_the_previous_outputs_byte_for_byte(tmp_path: Path) -> None:
    with OutputDir(tmp_path, "test") as out:
        out.write_text("a.txt", "old")
    before = snapshot(tmp_path)
    with pytest.raises(RuntimeError), OutputDir(tmp_path, "test") as out:
        out.write_text("a.txt", "new")
        raise RuntimeError("the computation failed")
    assert snapshot(tmp_path) == before


def test_refuses_to_overwrite_files_it_did_not_write_unless_forced(tmp_path: Path) -> None:
    (tmp_path / "summary.json").write_text("the user's own")
    with pytest.raises(OutputError, match=r"would overwrite files hpctl did not write .*summary\.json.*--force"):
        with OutputDir(tmp_path, "test", protect=("summary.json",)):
            pass
    # Not protected up front: refused when the run ends, nothing replaced.
    with pytest.raises(OutputError, match="summary.json"), OutputDir(tmp_path, "test") as out:
        out.write_text("summary.json", "{}")
    assert (tmp_path / "summary.json").read_text() == "the user's own"
    with OutputDir(tmp_path, "test", force=True) as out:
        out.write_text("summary.json", "{}")
    assert (tmp_path / "summary.json").read_text() == "{}"


def test_a_file_changed_since_hpctl_wrote_it_is_not_hpctls_any_more(tmp_path: Path) -> None:
    with OutputDir(tmp_path, "test") as out:
        out.write_text("fit.md", "generated")
    (tmp_path / "fit.md").write_text("generated, plus the user's notes")
    with pytest.raises(OutputError, match="fit.md"), OutputDir(tmp_path, "test") as out:
        out.write_text("fit.md", "regenerated")
    assert "notes" in (tmp_path / "fit.md").read_text()


def test_stale_outputs_of_the_same_command_are_removed_others_kept(tmp_path: Path) -> None:
    with OutputDir(tmp_path, "rig") as out:
        for name in ("a", "b"):
            write_record(record(), out.path(name))
    with OutputDir(tmp_path, "fit") as out:
        out.write_text("fit.json", "{}")
    (tmp_path / "notes.txt").write_text("the user's")
    with OutputDir(tmp_path, "rig") as out:
        write_record(record(), out.path("a"))
    assert sorted(visible(tmp_path)) == ["a.csv", "a.toml", "fit.json", "notes.txt"]
    assert out.removed == ["b.csv", "b.toml"]


def test_stale_output_changed_by_the_user_is_left_and_disowned(tmp_path: Path) -> None:
    with OutputDir(tmp_path, "rig") as out:
        out.write_text("b.txt", "hpctl's")
    (tmp_path / "b.txt").write_text("edited")
    with OutputDir(tmp_path, "rig") as out:
        out.write_text("a.txt", "x")
    assert (tmp_path / "b.txt").read_text() == "edited" and out.kept == ["b.txt"]
    assert "b.txt" not in json.loads((tmp_path / MANIFEST).read_text())["files"]


def test_fit_dir_does_not_fit_stale_records(tmp_path: Path) -> None:
    code, err = cli("rig", "--out", str(tmp_path), "--quiet")  # the five-sine program
    assert code == 0, err
    assert len(list(tmp_path.glob("*.toml"))) == 5
    code, err = cli("rig", "--out", str(tmp_path), "--quiet", "--effect", "leakage")  # adds the hold record
    assert code == 0, err
    assert len(list(tmp_path.glob("*.toml"))) == 6
    code, err = cli("rig", "--out", str(tmp_path), "--quiet")
    assert code == 0, err
    assert sorted(p.stem for p in tmp_path.glob("*.toml")) == ["sine_0.01hz", "sine_0.03hz", "sine_0.1hz", "sine_0.3hz", "sine_1hz"]


def test_output_names_stay_inside_the_folder(tmp_path: Path) -> None:
    with pytest.raises(OutputError, match="relative to the output folder"), OutputDir(tmp_path, "test") as out:
        out.path("../escape.txt")


# ---------------------------------------------------------------- the lock


def test_a_second_run_into_a_busy_folder_stops_with_the_first_ones_pid(tmp_path: Path) -> None:
    with OutputDir(tmp_path, "simulate"):
        with pytest.raises(OutputError, match=rf"in use by another hpctl run \(pid {os.getpid()}, hpctl simulate"):
            with OutputDir(tmp_path, "fit"):
                pass
        code, err = cli("simulate", "--test", "sdof-step", "--duration-s", "1", "--out", str(tmp_path))
        assert code == 2 and f"pid {os.getpid()}" in err
        # Readers wait for the writer too.
        with pytest.raises(OutputError, match="being written by an hpctl run"), reading(tmp_path):
            pass
    with OutputDir(tmp_path, "fit"):  # free again
        pass


def test_a_lock_left_by_a_dead_process_is_taken_over(tmp_path: Path) -> None:
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True, check=True)
    (tmp_path / LOCK).write_text(json.dumps({"pid": int(dead.stdout), "command": "simulate", "started_utc": "2026-01-01T00:00:00+00:00"}))
    stale_staging = tmp_path / ".hpctl-staging-999999"
    stale_staging.mkdir()
    (stale_staging / "half.csv").write_text("1,2")
    with OutputDir(tmp_path, "simulate") as out:
        out.write_text("a.txt", "x")
    assert (tmp_path / "a.txt").read_text() == "x"
    assert not stale_staging.exists() and not (tmp_path / LOCK).exists()


def test_a_lock_held_by_a_live_process_in_another_process(tmp_path: Path) -> None:
    holder = subprocess.Popen(
        [sys.executable, "-c", textwrap.dedent(f"""
            import sys, time
            from hpctl.data.output import OutputDir
            with OutputDir({str(tmp_path)!r}, "rig"):
                print("locked", flush=True)
                sys.stdin.readline()
        """)],
        stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
    )
    try:
        assert holder.stdout is not None and holder.stdout.readline().strip() == "locked"
        with pytest.raises(OutputError, match=rf"pid {holder.pid}, hpctl rig"):
            with OutputDir(tmp_path, "simulate"):
                pass
    finally:
        assert holder.stdin is not None
        holder.stdin.write("\n")
        holder.stdin.flush()
        holder.wait(timeout=30)
    with OutputDir(tmp_path, "simulate"):
        pass


# ----------------------------------------------------- full disk, Ctrl-C


def test_a_full_disk_leaves_the_previous_outputs(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    out_dir = tmp_path / "out"
    code, err = cli("rig", "--out", str(out_dir), "--quiet")
    assert code == 0, err
    before = snapshot(out_dir)
    real_open = Path.open

    def open_full(self: Path, mode: str = "r", *args: object, **kwargs: object) -> object:
        # The rerun's third record hits a full disk.
        if "w" in mode and self.name.endswith(".tmp") and "sine_0.1hz.csv" in self.name:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(self))
        return real_open(self, mode, *args, **kwargs)  # type: ignore[call-overload]

    monkeypatch.setattr(Path, "open", open_full)
    code, err = cli("rig", "--out", str(out_dir), "--quiet", "--seed", "7")
    assert code == 1
    assert "No space left on device" in err and f"the previous outputs in {out_dir} are unchanged" in err
    monkeypatch.undo()
    assert snapshot(out_dir) == before


def test_ctrl_c_while_writing_leaves_the_previous_outputs(tmp_path: Path) -> None:
    out_dir = tmp_path / "out"
    code, err = cli("rig", "--out", str(out_dir), "--quiet")
    assert code == 0, err
    before = snapshot(out_dir)
    # A rerun that stops (waits) while it writes its third record: Ctrl-C then.
    script = textwrap.dedent("""
        # A terminal delivers Ctrl-C to a process whose SIGINT is at its default;
        # a parent that ignores SIGINT (a background job of a non-interactive
        # shell, as CI may be) passes SIG_IGN on, and Python then never raises
        # KeyboardInterrupt. Start from what the user's terminal gives.
        import signal
        signal.signal(signal.SIGINT, signal.default_int_handler)
        import sys, time
        import hpctl.data.records as records
        from hpctl.cli import main
        real = records.write_record
        n = 0
        def slow(record, path):
            global n
            n += 1
            if n == 3:
                print("writing", flush=True)
                time.sleep(60)
            return real(record, path)
        records.write_record = slow
        import hpctl.cli.calibrate as calibrate
        calibrate.write_record = slow
        main(["rig", "--out", sys.argv[1], "--quiet", "--seed", "9"])
    """)
    p = subprocess.Popen([sys.executable, "-c", script, str(out_dir)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert p.stdout is not None
    assert p.stdout.readline().strip() == "writing"
    p.send_signal(signal.SIGINT)
    _, err = p.communicate(timeout=60)
    assert p.returncode == 130, err
    assert "interrupted" in err
    assert snapshot(out_dir) == before


def test_ctrl_c_during_the_renames_is_held_back_until_they_are_done(tmp_path: Path) -> None:
    with OutputDir(tmp_path, "test") as out:
        out.write_text("a.txt", "old a")
        out.write_text("b.txt", "old b")
    with pytest.raises(KeyboardInterrupt):
        with OutputDir(tmp_path, "test") as out:
            out.write_text("a.txt", "new a")
            out.write_text("b.txt", "new b")
            real_replace = os.replace

            def replace_then_interrupt(src: str | Path, dst: str | Path) -> None:
                real_replace(src, dst)
                if str(dst).endswith("a.txt"):  # Ctrl-C after the first of the two renames
                    os.kill(os.getpid(), signal.SIGINT)

            output.os.replace = replace_then_interrupt  # type: ignore[assignment]
            try:
                out.commit()
            finally:
                output.os.replace = real_replace  # type: ignore[assignment]
    assert (tmp_path / "a.txt").read_text() == "new a" and (tmp_path / "b.txt").read_text() == "new b"


# ----------------------------------------------------------- record pairs


def test_a_record_pair_from_two_writes_is_refused(tmp_path: Path) -> None:
    write_record(record(), tmp_path / "r")
    old_toml = (tmp_path / "r.toml").read_text()
    write_record(record(offset=1.0), tmp_path / "r")
    # What a reader could see between the CSV's rename and the TOML's.
    (tmp_path / "r.toml").write_text(old_toml)
    with pytest.raises(RecordError, match=r"r\.csv: does not match the csv_sha256 in r\.toml"):
        read_record(tmp_path / "r")


def test_a_truncated_csv_beside_its_toml_does_not_read_back_as_a_record(tmp_path: Path) -> None:
    csv_path, _ = write_record(record(n=50), tmp_path / "r")
    text = csv_path.read_text()
    csv_path.write_text(text[: len(text) // 2].rsplit("\n", 1)[0] + "\n")  # whole lines: a valid CSV on its own
    with pytest.raises(RecordError, match="csv_sha256"):
        read_record(tmp_path / "r")


def test_records_without_the_checksum_still_read(tmp_path: Path) -> None:
    csv_path, toml_path = write_record(record(), tmp_path / "r")
    toml_path.write_text("\n".join(line for line in toml_path.read_text().splitlines() if not line.startswith("csv_sha256")))
    csv_path.write_text(csv_path.read_text().replace("\n1.0,", "\n1.0000000001,"))
    assert read_record(tmp_path / "r")["time_s"][1] == pytest.approx(1.0)


def test_a_csv_without_its_toml_is_not_a_record(tmp_path: Path) -> None:
    write_record(record(), tmp_path / "r")
    record_paths(tmp_path / "r")[1].unlink()
    with pytest.raises(RecordError, match=r"r\.toml: file not found"):
        read_record(tmp_path / "r.csv")
    code, err = cli("fit", str(tmp_path), "--out", str(tmp_path / "fit"))
    assert code == 2 and f"no rig records (NAME.csv with NAME.toml) in {tmp_path}" in err


def test_write_record_leaves_no_temporary_files(tmp_path: Path) -> None:
    write_record(record(), tmp_path / "r")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.csv", "r.toml"]


def test_two_cli_runs_into_one_folder_do_not_interleave(tmp_path: Path) -> None:
    """Two real processes: the second stops at once, naming the first,
    which then finishes undisturbed."""
    # The first run waits, in the middle of writing its records, until told.
    script = textwrap.dedent("""
        import sys
        import hpctl.cli.simulate as simulate
        from hpctl.cli import main
        real = simulate.write_record
        def paused(record, path):
            print("writing", flush=True)
            sys.stdin.readline()
            return real(record, path)
        simulate.write_record = paused
        main(["simulate", "--test", "sdof-step", "--duration-s", "1", "--spring", "hard", "--damper", "on", "--out", sys.argv[1], "--quiet"])
    """)
    first = subprocess.Popen([sys.executable, "-c", script, str(tmp_path)], stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert first.stdout is not None and first.stdout.readline().strip() == "writing"
    second = subprocess.run([sys.executable, "-m", "hpctl", "simulate", "--test", "sdof-step", "--duration-s", "1", "--out", str(tmp_path), "--quiet"],
                            capture_output=True, text=True, check=False)
    _, first_err = first.communicate("\n", timeout=120)
    assert second.returncode == 2 and f"is in use by another hpctl run (pid {first.pid}, hpctl simulate" in second.stderr
    assert first.returncode == 0, first_err
    assert read_record(tmp_path / "records" / "sdof_step_hard_on").kind == "sdof"
    assert json.loads((tmp_path / "summary.json").read_text())["runs"][0]["damper"] == "on"
