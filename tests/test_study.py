"""`rtlab study` (app/study.py): the bench with the study's protocol, resumable: a scene measured
once is kept, and a run started again with the same settings takes it instead of measuring it;
other settings measure it anew."""
import json
import subprocess
import sys


def _study(*args, timeout=600):
    return subprocess.run([sys.executable, "-m", "app.cli", "study", "--quick", *args], capture_output=True, text=True,
                          timeout=timeout)


def test_a_study_goes_on_where_it_stopped(tmp_path):
    out = tmp_path / "study"
    first = _study("arcade", "--configs", "forward,ao_1", "--out", str(out))
    assert first.returncode == 0, first.stderr[-2000:]
    kept = out / "scenes" / "arcade.json"
    assert kept.exists()
    doc = json.loads((out / "results.json").read_text())
    assert {r["config"] for r in doc["results"]} == {"forward", "ao_1"}
    assert all(r.get("quality") for r in doc["results"] if r["config"] == "ao_1")  # quality measured
    stamp = kept.stat().st_mtime_ns
    # "stopped" after the arcade: the next run takes it and measures the street only
    again = _study("arcade", "street", "--configs", "forward,ao_1", "--out", str(out))
    assert again.returncode == 0, again.stderr[-2000:]
    assert "arcade: measured before" in again.stderr and kept.stat().st_mtime_ns == stamp
    doc = json.loads((out / "results.json").read_text())
    assert sorted({r["scene"] for r in doc["results"]}) == ["arcade", "street"]
    assert "## Recommendations" in (out / "report.md").read_text()
    # other settings: measured anew
    other = _study("arcade", "--configs", "forward,shadows_one", "--out", str(out))
    assert other.returncode == 0 and "measured before" not in other.stderr, other.stderr[-2000:]
    assert {r["config"] for r in json.loads((out / "results.json").read_text())["results"]} == {"forward",
                                                                                               "shadows_one"}


def test_study_errors_are_one_line(tmp_path):
    bad = _study("nowhere", "--out", str(tmp_path / "s"), timeout=120)
    assert bad.returncode == 2 and "Traceback" not in bad.stderr and len(bad.stderr.strip().splitlines()) == 1
