"""Error classes, messages, and the core types' JSON round trip."""

from __future__ import annotations

import subprocess
import sys

import pytest

from nsrmp_bench import errors
from nsrmp_bench._optional import require
from nsrmp_bench.config import EpisodeConfig
from nsrmp_bench.generators.sampler import sample_episode
from nsrmp_bench.generators.scene_sampler import sample_scene
from nsrmp_bench.scene import Pose, Scene, SceneObject


def test_one_base_class() -> None:
    for name in errors.__all__:
        cls = getattr(errors, name)
        assert issubclass(cls, errors.NSRMPError)


def test_unknown_shape_and_colour_name_the_fix() -> None:
    with pytest.raises(errors.InvalidArgument, match=r"unknown shape 'sphere'; expected one of cube, dice, lego"):
        SceneObject("sphere", "red")
    with pytest.raises(errors.InvalidArgument, match="unknown colour 'purple'"):
        SceneObject("cube", "purple")


def test_scene_needs_one_pose_per_object() -> None:
    with pytest.raises(errors.InvalidArgument, match="got 1 objects and 0 poses"):
        Scene((SceneObject("cube", "red"),), ())
    with pytest.raises(errors.InvalidArgument, match=r"pose\.position must be 3 finite numbers"):
        Pose.from_dict({"position": [0, 0, float("nan")], "orientation": [0, 0, 0, 1]})


def test_sampler_arguments_are_checked() -> None:
    import numpy as np

    rng = np.random.default_rng(0)
    with pytest.raises(errors.InvalidArgument, match=r"n_objects=16 is out of range; expected 3..15"):
        sample_scene(rng, 16)
    with pytest.raises(errors.InvalidArgument, match=r"relational='maybe'"):
        EpisodeConfig(relational="maybe")
    with pytest.raises(errors.InvalidArgument, match=r"phrasing='poetic'"):
        EpisodeConfig(phrasing="poetic")


def test_generation_error_after_bounded_attempts() -> None:
    # one step that needs a relation among 3 objects in a sampled scene can fail; with one
    # attempt allowed for an impossible policy mix the error names the fix.
    with pytest.raises(errors.GenerationError, match=r"no valid episode in 1 attempts.*Relax the config"):
        for i in range(200):
            sample_episode(EpisodeConfig(objects=3, steps=7, relational="needed"), 0, i, "x",
                           max_attempts=1)


def test_missing_extra_names_the_install_command() -> None:
    with pytest.raises(errors.MissingExtra, match=r"pip install 'nsrmp-bench\[all\]'"):
        require("surely_not_a_real_module_xyz")


def test_unknown_id_message_is_not_quoted() -> None:
    assert str(errors.UnknownId("no split 'x'; did you mean 'y'")) == "no split 'x'; did you mean 'y'"


def test_sample_cli_same_bytes_in_other_processes() -> None:
    cmd = [sys.executable, "-m", "nsrmp_bench.cli.main", "sample", "--seed", "7",
           "--objects", "12", "--steps", "5"]
    outs = {subprocess.run(cmd, capture_output=True, check=True).stdout for _ in range(2)}
    assert len(outs) == 1
    assert b'"instruction"' in next(iter(outs))


def test_cli_reports_bad_input_without_traceback() -> None:
    cmd = [sys.executable, "-m", "nsrmp_bench.cli.main", "sample", "--objects", "20"]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    assert proc.returncode == 2
    assert "n_objects=20 is out of range" in proc.stderr
    assert "Traceback" not in proc.stderr
