"""Bad input on the command line: one `error:` line naming the problem, exit 2, nothing written, no work done first."""

from __future__ import annotations

import json

from test_cli import assert_clean_error, run_cli


def test_a_ring_too_large_is_refused_before_anything_is_built(tmp_path):
    res = run_cli("evaluate", "sample", "--ring-frames", "1000000000", "--out", str(tmp_path / "out"), cwd=tmp_path)
    assert res.returncode == 2
    assert_clean_error(res, "--ring-frames", "100,000", "1,000,000,000")
    assert not (tmp_path / "out").exists()


def test_a_feature_density_that_would_take_the_memory_is_refused_before_allocation(tmp_path):
    res = run_cli("evaluate", "sample", "--ring-frames", "2", "--feature-density", "1e9", "--out", str(tmp_path / "o"),
                  cwd=tmp_path)
    assert res.returncode == 2  # not a MemoryError for 33 TiB
    assert_clean_error(res, "feature density of 1e+09 per m²", "more than the 20,000,000 allowed")
    assert not (tmp_path / "o").exists()


def test_an_output_folder_that_cannot_be_written_is_refused_first(tmp_path):
    (tmp_path / "a-file").write_text("x")
    res = run_cli("evaluate", "sample", "--ring-frames", "4", "--out", str(tmp_path / "a-file" / "out"), cwd=tmp_path)
    assert res.returncode == 2
    assert_clean_error(res, "--out", "cannot write there")
    assert "casting" not in res.stdout  # refused before any frame was cast


def test_a_capture_date_needs_a_schedule(tmp_path):
    res = run_cli("evaluate", "sample", "--ring-frames", "4", "--date", "2024-05-01", "--out", str(tmp_path / "o"),
                  cwd=tmp_path)
    assert res.returncode == 2
    assert_clean_error(res, "--date 2024-05-01", "--schedule")
    assert not (tmp_path / "o" / "report.json").exists()


def test_an_error_message_keeps_its_brackets(tmp_path):
    """The value in a message is printed as it is, not taken for console markup."""
    plan = {"format": "sightplan-plan", "version": 1,
            "cameras": {"c": {"model": "pinhole", "width": 64, "height": 48, "fx": 50, "fy": 50, "cx": 32, "cy": 24}},
            "frames": [{"name": "f0", "camera": "c", "position": [float("nan"), -13.0, 4.49],
                        "rotation": [[1, 0, 0], [0, 1, 0], [0, 0, 1]]}]}
    path = tmp_path / "nan.json"
    path.write_text(json.dumps(plan))
    res = run_cli("evaluate", "sample", str(path), "--out", str(tmp_path / "o"), cwd=tmp_path)
    assert res.returncode == 2
    assert_clean_error(res, "position", "not finite", "[NaN, -13, 4.49]")


def test_check_refuses_a_json_path_it_cannot_write_before_checking(tmp_path):
    (tmp_path / "a-file").write_text("x")
    res = run_cli("plan", "orbit", "sample", "--safety-distance", "8", "-o", str(tmp_path / "p.json"), cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    res = run_cli("check", str(tmp_path / "p.json"), "sample", "--json", str(tmp_path / "a-file" / "r.json"),
                  cwd=tmp_path)
    assert res.returncode == 2
    assert_clean_error(res, "--json", "cannot write there")
    assert "mission" not in res.stdout  # refused before the checks ran


def test_a_lawnmower_too_fine_and_a_number_that_is_not_one_are_one_error_line(tmp_path):
    """`--gsd 1e-4` flies the camera into the roof (12,312 frames once); `--safety-distance nan` is no number."""
    out = tmp_path / "lm.json"
    res = run_cli("plan", "lawnmower", "sample", "--gsd", "1e-4", "-o", str(out), cwd=tmp_path)
    assert res.returncode == 2
    assert_clean_error(res, "--gsd", "0.0001", "above the model's top", "give at least")
    for option, value, shown in (("--safety-distance", "nan", "NaN"), ("--vlos-radius", "inf", "Infinity")):
        res = run_cli("plan", "orbit", "sample", option, value, "-o", str(out), cwd=tmp_path)
        assert res.returncode == 2
        assert_clean_error(res, f"{option}: {shown} is not a finite number")
    assert not out.exists()
