"""What a new user runs into first: output folders, signals, names, messages.

Each test is one or a few CLI calls on real data and an assertion on the exit status and
the message.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from nsrmp_bench.cli.main import main
from nsrmp_bench.config import EpisodeConfig
from nsrmp_bench.generators.sampler import sample_episode

SPLIT = "newcomer-v1"


def cli(*args: str | Path) -> int:
    return main([str(a) for a in args])


@pytest.fixture(scope="module")
def data(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Six symbolic episodes as JSON Lines (the scorer reads them like a data directory)."""
    configs = [EpisodeConfig(objects=4, steps=1), EpisodeConfig(objects=6, steps=2)]
    eps = [sample_episode(configs[i % 2], 7, i, f"{SPLIT}-test-{i:06d}", max_attempts=200)
           for i in range(6)]
    path = tmp_path_factory.mktemp("newcomer") / "episodes.jsonl"
    path.write_text("".join(json.dumps(e.to_dict()) + "\n" for e in eps), "utf-8")
    return path


# 1. Output folders ---------------------------------------------------------------------

def test_every_writer_creates_a_missing_output_folder(tmp_path: Path, data: Path) -> None:
    new = tmp_path / "not" / "yet"
    noop, oracle = new / "a" / "noop.jsonl", new / "b" / "oracle.jsonl"
    assert cli("baseline", "noop", "--data", data, "--out", noop, "--split", SPLIT) == 0
    assert cli("baseline", "oracle", "--data", data, "--out", oracle, "--split", SPLIT) == 0
    assert cli("score", noop, "--data", data, "--split", SPLIT, "--n-boot", "0", "--quiet",
               "--json", new / "c" / "s.json", "--per-instance", new / "d" / "p.csv") == 0
    assert cli("compare", oracle, noop, "--data", data, "--split", SPLIT, "--n-boot", "0",
               "--n-perm", "10", "--quiet", "--json", new / "e" / "c.json") == 0
    written = sorted(p.relative_to(new).as_posix() for p in new.rglob("*") if p.is_file())
    assert written == ["a/noop.jsonl", "b/oracle.jsonl", "c/s.json", "d/p.csv", "e/c.json"]
    assert json.loads((new / "c" / "s.json").read_text())["split"] == SPLIT


@pytest.mark.sim
def test_the_writers_on_rendered_data_create_a_missing_output_folder(
        tmp_path: Path, smoke_v2_test: Path) -> None:
    for extra in ("cv2", "torch", "mcap"):
        pytest.importorskip(extra)
    new = tmp_path / "not" / "yet"
    dets, oracle = new / "a" / "dets.jsonl", tmp_path / "oracle.jsonl"
    assert cli("detect", "--detector", "classical", "--data", smoke_v2_test, "--out", dets,
               "--quiet") == 0
    assert cli("score-detections", dets, "--data", smoke_v2_test,
               "--json", new / "b" / "s.json") == 0
    assert cli("predict", "nsrm", "--data", smoke_v2_test, "--out", new / "c" / "p.jsonl",
               "--quiet") == 0
    assert cli("baseline", "oracle", "--data", smoke_v2_test, "--out", oracle) == 0
    assert cli("replay", oracle, "--data", smoke_v2_test, "--out", new / "d" / "r.jsonl",
               "--limit", "1", "--quiet") == 0
    first = json.loads(oracle.read_text().splitlines()[1])["id"]
    assert cli("export-mcap", smoke_v2_test, "--out", new / "e" / "x.mcap",
               "--episodes", first) == 0
    written = sorted(p.relative_to(new).as_posix() for p in new.rglob("*") if p.is_file())
    assert written == ["a/dets.jsonl", "b/s.json", "c/p.jsonl", "d/r.jsonl", "e/x.mcap"]


def test_a_folder_where_a_file_is_meant_is_refused_before_any_work(
        tmp_path: Path, data: Path, capsys: pytest.CaptureFixture[str]) -> None:
    folder = tmp_path / "here"
    folder.mkdir()
    for argv in (("baseline", "noop", "--data", data, "--split", SPLIT, "--out", folder),
                 ("score", data, "--data", data, "--json", folder),
                 ("export-mcap", data, "--out", folder)):
        with pytest.raises(SystemExit) as stop:
            cli(*argv)
        assert stop.value.code == 2
        err = capsys.readouterr().err
        assert f"'{folder}' is a folder, but a file is meant here" in err
    assert list(folder.iterdir()) == []  # no .tmp left behind
    a_file = tmp_path / "file.jsonl"
    a_file.write_text("x\n")
    with pytest.raises(SystemExit) as stop:
        cli("generate", "--split", "smoke-v2", "--out", a_file)
    assert stop.value.code == 2
    assert "is a file, but a folder is meant here" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        cli("baseline", "noop", "--data", data, "--split", SPLIT, "--out", a_file / "x.jsonl")
    assert f"'{a_file}' is a file, not a folder" in capsys.readouterr().err


def test_atomic_write_leaves_nothing_on_failure(tmp_path: Path) -> None:
    from nsrmp_bench.storage.atomic import atomic_open, atomic_write_text

    target = tmp_path / "deep" / "er" / "out.txt"
    assert atomic_write_text(target, "one\n") == target
    assert target.read_text() == "one\n"
    with pytest.raises(RuntimeError), atomic_open(target) as fh:
        fh.write("half")
        raise RuntimeError
    assert target.read_text() == "one\n"
    assert sorted(p.name for p in target.parent.iterdir()) == ["out.txt"]


# 2. SIGTERM ----------------------------------------------------------------------------

def _descendants(pid: int) -> set[int]:
    """Every process below ``pid`` (read from /proc)."""
    parents: dict[int, int] = {}
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        parents[int(stat.parent.name)] = int(fields[1])
    found, frontier = set(), {pid}
    while frontier:
        frontier = {c for c, p in parents.items() if p in frontier} - found
        found |= frontier
    return found


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


def _cmdline(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/cmdline").read_text().replace("\0", " ")
    except OSError:
        return ""


def _all_end(pids: set[int], within_s: float = 60) -> list[int]:
    """The processes of ``pids`` still alive after waiting up to ``within_s`` for them."""
    import time

    deadline = time.monotonic() + within_s
    while (left := [pid for pid in pids if _alive(pid)]) and time.monotonic() < deadline:
        time.sleep(0.1)
    return left


def _generate(out: Path, *engine: str) -> list[str]:
    """``generate`` of smoke-v2 into ``out``, a shard per episode (argv without the program):
    each stop below leaves shards to do."""
    return ["generate", "--split", "smoke-v2", "--out", str(out), "--shard-size", "1",
            "--quiet", *engine]


def _start(argv: list[str], *, session: bool = False) -> Any:
    """The command in a new process (``session``: the leader of its own process group, as a
    terminal's foreground job is)."""
    import subprocess
    import sys

    return subprocess.Popen([sys.executable, "-m", "nsrmp_bench.cli.main", *argv],
                            stderr=subprocess.PIPE, text=True, start_new_session=session)


def _when_writing(proc: Any, out: Path, after: float) -> set[int]:
    """Wait until a worker of ``proc`` writes a shard begun after ``after`` (a time.time());
    the run's processes then. A ``*.tmp`` an earlier, stopped run left (its workers may
    touch it while they are being stopped) does not count: only one that appears now."""
    import time

    stale = {t.name for t in out.glob("test/*.h5.tmp")}
    deadline = time.monotonic() + 180

    def begun() -> bool:
        for t in out.glob("test/*.h5.tmp"):
            try:
                if t.name not in stale and t.stat().st_mtime >= after:
                    return True
            except FileNotFoundError:  # renamed into place meanwhile
                continue
        return False

    while not begun():
        assert proc.poll() is None and time.monotonic() < deadline, proc.stderr
        time.sleep(0.05)
    return _descendants(proc.pid)


def _resumed_to_the_committed_bytes(out: Path, *engine: str) -> None:
    from nsrmp_bench.official_manifests import official_manifest

    assert not (out / "test" / "manifest.json").exists()
    assert main(_generate(out, *engine)) == 0
    manifest = json.loads((out / "test" / "manifest.json").read_text())
    committed = official_manifest("smoke-v2", "test")
    assert committed is not None and manifest["root_hash"] == committed["root_hash"]
    assert not list(out.glob("test/*.tmp"))


@pytest.mark.slow
@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads /proc (Linux)")
def test_sigterm_stops_generate_and_its_workers_then_it_resumes(tmp_path: Path) -> None:
    pytest.importorskip("pybullet")
    import signal
    import time

    out = tmp_path / "smoke"
    proc = _start(_generate(out, "--workers", "2"))
    run = _when_writing(proc, out, 0.0)
    assert len(run) >= 3  # two workers, the manager (and the resource tracker)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 143, err
    assert "stopped by SIGTERM" in err and "Traceback" not in err
    assert _all_end(run) == []
    assert not (out / "test" / "manifest.json").exists()

    # the driver disappears (SIGKILL: no clean-up of its own): its workers notice and end
    proc = _start(_generate(out, "--workers", "2"))
    run = _when_writing(proc, out, time.time())
    assert len(run) >= 3
    proc.kill()
    proc.communicate(timeout=60)
    assert _all_end(run) == []

    _resumed_to_the_committed_bytes(out, "--workers", "1")


def _no_shutdown_noise(err: str) -> None:
    """No traceback, and none of the Dask workers' complaints at being stopped mid-task."""
    for noise in ("Traceback", "CancelledError", " - ERROR - ", "still alive after"):
        assert noise not in err, err


@pytest.mark.slow
@pytest.mark.sim
@pytest.mark.dask
@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads /proc (Linux)")
def test_sigterm_or_a_killed_driver_stops_the_dask_cluster_then_generate_resumes(
        tmp_path: Path) -> None:
    pytest.importorskip("pybullet")
    pytest.importorskip("distributed")
    import os
    import signal
    import time

    out = tmp_path / "smoke"
    dask = ("--engine", "dask", "--workers", "2")
    proc = _start(_generate(out, *dask))
    run = _when_writing(proc, out, 0.0)
    workers = [pid for pid in run if "spawn_main" in _cmdline(pid)]
    assert len(workers) == 2  # the LocalCluster's workers (its nannies run in the driver)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 143, err
    assert "nsrmp-bench generate: stopped by SIGTERM; its workers are stopped" in err
    _no_shutdown_noise(err)
    assert _all_end(run) == []
    assert not (out / "test" / "manifest.json").exists()

    # Ctrl-C at a terminal reaches every process of the command: the same stop and message
    proc = _start(_generate(out, *dask), session=True)
    run = _when_writing(proc, out, time.time())
    os.killpg(proc.pid, signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert "nsrmp-bench generate: stopped by Ctrl-C; its workers are stopped" in err
    _no_shutdown_noise(err)
    assert _all_end(run) == []

    # the driver disappears (SIGKILL: no clean-up of its own): its workers notice and end
    proc = _start(_generate(out, *dask))
    run = _when_writing(proc, out, time.time())
    assert len([pid for pid in run if "spawn_main" in _cmdline(pid)]) == 2
    proc.kill()
    proc.communicate(timeout=60)
    assert _all_end(run) == []

    _resumed_to_the_committed_bytes(out, *dask)  # the same command resumes


@pytest.mark.slow
@pytest.mark.sim
@pytest.mark.dask
@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads /proc (Linux)")
def test_sigterm_while_the_dask_cluster_starts_stops_it_whole(smoke_v2_test: Path) -> None:
    """Before the fix Dask's exit hook failed on the half-started nannies, with a traceback."""
    pytest.importorskip("distributed")
    import signal
    import time

    proc = _start(["verify", str(smoke_v2_test), "--engine", "dask", "--workers", "2"])
    deadline = time.monotonic() + 120
    while len([pid for pid in _descendants(proc.pid) if "spawn_main" in _cmdline(pid)]) < 2:
        assert proc.poll() is None and time.monotonic() < deadline, proc.stderr
        time.sleep(0.01)
    proc.send_signal(signal.SIGTERM)  # the LocalCluster's nannies are starting its workers
    run: set[int] = set()
    while proc.poll() is None and time.monotonic() < deadline:
        run |= _descendants(proc.pid)
        time.sleep(0.01)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 143, err
    assert "nsrmp-bench verify: stopped by SIGTERM" in err
    _no_shutdown_noise(err)
    assert run and _all_end(run) == []


# 3. A retrained model is not the shipped one -------------------------------------------

def test_a_checkpoint_that_is_not_the_shipped_one_gets_its_own_name(
        tmp_path: Path, smoke_v2_test: Path, capsys: pytest.CaptureFixture[str]) -> None:
    pytest.importorskip("torch")
    import shutil

    from nsrmp_bench.reference_model.checkpoints import (
        read_torch_file,
        save_checkpoint,
        shipped_checkpoint,
    )
    from nsrmp_bench.reference_model.part_prediction import checkpoint_label

    shipped = shipped_checkpoint("nsrm-v2")
    same = tmp_path / "copy" / "best.pt"
    same.parent.mkdir()
    shutil.copyfile(shipped, same)
    assert checkpoint_label("nsrm-v2", same) == "nsrm-v2"  # the same bytes: the shipped one

    payload = read_torch_file(shipped)
    state = dict(payload["state"])
    key = next(k for k, v in state.items() if v.is_floating_point())
    state[key] = state[key] + 0.01
    retrained = save_checkpoint(tmp_path / "run7" / "best.pt", "nsrm-v2", payload["config"],
                                payload["vocab"], state, payload["extra"])
    label = checkpoint_label("nsrm-v2", retrained)
    assert label.startswith("nsrm-v2@run7-") and len(label) == len("nsrm-v2@run7-") + 8

    pred = tmp_path / "mine.jsonl"
    assert cli("predict", "nsrm-v2", "--data", smoke_v2_test, "--checkpoint", retrained,
               "--out", pred, "--quiet") == 0
    header = json.loads(pred.read_text().splitlines()[0])["header"]
    assert header["model"] == label and header["base_model"] == "nsrm-v2"
    noop = tmp_path / "noop.jsonl"
    assert cli("baseline", "noop", "--data", smoke_v2_test, "--out", noop) == 0
    capsys.readouterr()
    assert cli("compare", pred, noop, "--data", smoke_v2_test, "--n-boot", "0",
               "--n-perm", "10") == 0
    assert label in capsys.readouterr().out


# 5. evaluate refuses a model scored twice before it scores anything --------------------

def test_evaluate_refuses_two_files_of_one_model_first(
        tmp_path: Path, smoke_v2_root: Path, capsys: pytest.CaptureFixture[str]) -> None:
    root = tmp_path / "data"
    root.mkdir()
    (root / "smoke-v2").symlink_to(smoke_v2_root, target_is_directory=True)
    one, two = tmp_path / "one.jsonl", tmp_path / "two.jsonl"
    for path in (one, two):
        assert cli("baseline", "noop", "--data", root / "smoke-v2" / "test", "--out", path) == 0
    capsys.readouterr()
    out = tmp_path / "results"
    assert cli("evaluate", one, two, "--data-root", root, "--out", out, "--workers", "1") == 2
    err = capsys.readouterr().err
    assert f"{one} and {two} are both model 'noop-v1' on smoke-v2/test" in err
    assert "--name NAME" in err
    assert not out.exists()  # nothing was scored or written


# 6. Scoring from Python ----------------------------------------------------------------

def test_score_takes_a_list_of_predictions_and_an_open_collection(
        tmp_path: Path, smoke_v2_test: Path) -> None:
    import warnings

    import nsrmp_bench as nb
    from nsrmp_bench.errors import InvalidArgument
    from nsrmp_bench.scoring.submission import Prediction

    data = nb.open(smoke_v2_test)
    noop = []
    for i in range(len(data)):
        ep = data.episode(i, images=False)
        assert ep.rendering is not None
        noop.append(Prediction(id=ep.id, boxes=ep.rendering.targets.boxes_amodal[0]))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        result = nb.score(noop, data, n_boot=0)  # the collection knows its split
    assert result.split == "smoke-v2/test" and not result.warnings
    assert result.counts["predicted"] == len(data)

    file = tmp_path / "noop.jsonl"
    assert cli("baseline", "noop", "--data", smoke_v2_test, "--out", file) == 0
    from_file = nb.score(file, smoke_v2_test, n_boot=0)
    assert from_file.headline == pytest.approx(result.headline)
    assert not nb.score(file, data, n_boot=0).warnings

    episodes = [data.episode(i, images=False) for i in range(len(data))]
    with pytest.raises(InvalidArgument, match=r"pass split='smoke-v2/test'"):
        nb.score(noop, episodes)  # nothing names the split
    assert nb.score(noop, episodes, split="smoke-v2/test", n_boot=0).headline == \
        pytest.approx(result.headline)
    with pytest.raises(InvalidArgument, match=r"predictions\[1\] is a str"):
        nb.score([noop[0], "x"], data)


# 7. The package and its objects at the prompt ------------------------------------------

def test_dir_and_short_reprs(smoke_v2_test: Path, tmp_path: Path) -> None:
    import nsrmp_bench as nb

    assert {"open", "score", "load_model", "__version__"} <= set(dir(nb))
    assert "TYPE_CHECKING" not in dir(nb)
    data = nb.open(smoke_v2_test)
    ep = data[0]
    text = repr(ep)
    assert len(text) < 300 and ep.id in text and "rendered state" in text
    assert " 1 steps" not in text
    file = tmp_path / "noop.jsonl"
    assert cli("baseline", "noop", "--data", smoke_v2_test, "--out", file) == 0
    result = nb.score(file, data, n_boot=0)
    assert len(repr(result).splitlines()) == 1 and "iou_m=" in repr(result)


# 10. check-submission without --data, and a file that predicts nothing -----------------

def test_check_submission_uses_the_committed_manifest_and_refuses_nothing_predicted(
        tmp_path: Path, smoke_v2_test: Path, capsys: pytest.CaptureFixture[str]) -> None:
    good = tmp_path / "noop.jsonl"
    assert cli("baseline", "noop", "--data", smoke_v2_test, "--out", good) == 0
    capsys.readouterr()
    assert cli("check-submission", good, "--split", "smoke-v2") == 0
    out = capsys.readouterr().out
    assert "16 of 16 instances predicted" in out and "committed manifest" in out

    lines = good.read_text().splitlines()
    record = json.loads(lines[2])
    record["boxes"] = record["boxes"][:-1]
    for key in ("step_boxes", "positions"):
        record.pop(key, None)
    bad = tmp_path / "bad.jsonl"
    bad.write_text("\n".join([lines[0], lines[1], json.dumps(record)]) + "\n")
    assert cli("check-submission", bad, "--split", "smoke-v2") == 2
    err = capsys.readouterr().err
    n = len(record["boxes"])
    assert f"line 3: 'boxes' has {n} boxes but instance {record['id']!r} has {n + 1}" in err

    header_only = tmp_path / "header.jsonl"
    header_only.write_text(lines[0] + "\n")
    assert cli("check-submission", header_only, "--split", "smoke-v2") == 2
    assert "holds a header but no prediction" in capsys.readouterr().err
    assert cli("score", header_only, "--data", smoke_v2_test, "--n-boot", "0") == 2
    assert "not one instance of smoke-v2/test is predicted" in capsys.readouterr().err


# 8. Messages that lead somewhere ---------------------------------------------------------

def _refused_at_parse(capsys: pytest.CaptureFixture[str], *argv: str | Path) -> str:
    with pytest.raises(SystemExit) as stop:
        cli(*argv)
    assert stop.value.code == 2
    return capsys.readouterr().err


def test_messages_name_what_was_given_and_the_way_on(
        tmp_path: Path, smoke_v2_root: Path, smoke_v2_test: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    data_root = tmp_path / "data"
    data_root.mkdir()
    (data_root / "smoke-v2").symlink_to(smoke_v2_root, target_is_directory=True)
    assert cli("info", data_root) == 2  # a folder of split roots
    err = capsys.readouterr().err
    assert "is a data root holding the split roots smoke-v2/ (parts test)" in err
    assert f"e.g. {data_root / 'smoke-v2' / 'test'}" in err and "resume" not in err

    noop = tmp_path / "noop.jsonl"
    assert cli("baseline", "noop", "--data", smoke_v2_test / "manifest.json", "--out",
               noop) == 0  # a part's manifest stands for its part
    assert cli("score", noop, "--data", smoke_v2_test / "manifest.json", "--n-boot", "0",
               "--quiet") == 0
    capsys.readouterr()

    assert cli("evaluate", "noop", "--data-root", data_root / "smoke-v2", "--out",
               tmp_path / "r", "--workers", "1") == 2
    err = capsys.readouterr().err
    assert "is a split root (the parts test of one split)" in err
    assert f"pass {smoke_v2_root.resolve().parent}" in err

    assert cli("check-submission", noop, "--split", "foo-v9") == 2
    err = capsys.readouterr().err
    assert "'foo-v9' is not a shipped split" in err and "--split smoke-v2/test" in err
    assert "write 'foo-v9' in the header" not in err

    out = tmp_path / "gen"
    err = _refused_at_parse(capsys, "generate", "--split", "smoke-v2", "--out", out,
                            "--shard-size", "0")
    assert "argument --shard-size: expected a whole number >= 1, got '0'" in err
    err = _refused_at_parse(capsys, "generate", "--split", "smoke-v2", "--out", out,
                            "--limit", "-1")
    assert "argument --limit: expected a whole number >= 1, got '-1'" in err
    assert not out.exists()
    err = _refused_at_parse(capsys, "sample", "--seed", "-1")
    assert "argument --seed: expected a whole number >= 0, got '-1'" in err

    from nsrmp_bench.detection.detections import read_detections
    from nsrmp_bench.errors import InvalidArgument

    with pytest.raises(InvalidArgument, match=r"is a predictions file .* not a detections "
                       r"file; make detections of the part with `nsrmp-bench detect"):
        read_detections(noop)


def test_verify_of_a_damaged_shard_does_not_ask_for_the_whole_part(
        tmp_path: Path, smoke_v2_test: Path, capsys: pytest.CaptureFixture[str]) -> None:
    import shutil

    part = tmp_path / "test"
    shutil.copytree(smoke_v2_test, part)
    shard = sorted(part.glob("*.h5"))[0]
    raw = bytearray(shard.read_bytes())
    middle = len(raw) // 2
    raw[middle:middle + 4000] = bytes(b ^ 0xFF for b in raw[middle:middle + 4000])
    shard.write_bytes(bytes(raw))
    assert cli("verify", part) == 1
    out = capsys.readouterr().out
    assert "unreadable" in out and "no --limit" not in out
    assert "delete those shards and rerun" in " ".join(out.split())


# 9. Custom specs are checked whole, before anything starts -----------------------------

@pytest.mark.parametrize(("change", "path", "shown"), [
    (lambda s: s["parts"]["test"]["strata"][1].update(steps=[99]),
     "parts.test.strata[1].steps[0]", "99; expected a number of steps in 1..7"),
    (lambda s: s.update(image=[-1, 0]), "image[0]", "-1; 'image' is [width, height]"),
    (lambda s: s["parts"]["test"]["strata"][0].update(phrasing=["poetic"]),
     "parts.test.strata[0].phrasing[0]", "'poetic'; expected one of"),
    (lambda s: s["held_out_pairs"].append(["cube", "purple"]),
     "held_out_pairs[5]", "['cube', 'purple'] is not a [shape, colour]"),
])
def test_a_bad_spec_value_is_named_by_its_json_path(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], change: Any, path: str,
        shown: str) -> None:
    from importlib import resources

    spec = json.loads(resources.files("nsrmp_bench.splits").joinpath("smoke-v2.json")
                      .read_text("utf-8"))
    spec["id"] = "mine-v1"
    change(spec)
    file = tmp_path / "mine-v1.json"
    file.write_text(json.dumps(spec))
    for argv in (("info", "--spec", file),
                 ("generate", "--spec", file, "--out", tmp_path / "out", "--workers", "1")):
        assert cli(*argv) == 2
        err = capsys.readouterr().err
        assert f"{file} {path}: {shown}" in err
    assert not (tmp_path / "out").exists()


# 11. Output kept in a log stays whole --------------------------------------------------

def test_tables_stay_whole_when_output_is_redirected(
        tmp_path: Path, data: Path, capsys: pytest.CaptureFixture[str],
        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("COLUMNS", raising=False)  # captured output is not a terminal
    noop = tmp_path / "noop.jsonl"
    assert cli("baseline", "noop", "--data", data, "--out", noop, "--split", SPLIT) == 0
    capsys.readouterr()
    assert cli("score", noop, "--data", data, "--split", SPLIT, "--n-boot", "20",
               "--breakdown", "all") == 0
    out = capsys.readouterr().out
    assert "…" not in out
    assert "program exact" in out and "predicate (per step)" in out
    assert max(len(line) for line in out.splitlines()) > 80
    import os

    assert "COLUMNS" not in os.environ  # restored after the command


# 12. Help and plurals ------------------------------------------------------------------

def test_top_level_help_is_grouped_with_a_start_here(
        capsys: pytest.CaptureFixture[str]) -> None:
    from nsrmp_bench.cli.main import GROUPS, VERBS

    assert sorted(v for verbs in GROUPS.values() for v in verbs) == sorted(VERBS)
    assert cli() == 0
    out = capsys.readouterr().out
    assert "start here" in out and "nsrmp-bench generate --split smoke-v2" in out
    for group in GROUPS:
        assert f"\n{group}:\n" in out
    for verb in ("predict", "evaluate"):
        with pytest.raises(SystemExit):
            cli(verb, "--help")
        assert "(nsrm)" not in capsys.readouterr().out
    assert "(nsrm)" not in VERBS["train"]

    from nsrmp_bench.plurals import counted

    assert (counted(1, "file"), counted(2, "file"), counted(0, "step")) == \
        ("1 file", "2 files", "0 steps")
