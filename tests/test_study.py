"""Study files (cases/studies/*.toml): validated like case files, written back unchanged."""

from __future__ import annotations

import dataclasses

import pytest
import tomli_w

from magfem.config import CaseError, to_table
from magfem.study import Study, load_studies, load_study

GOOD = {
    "title": "Probe",
    "case": "cases/self_clean.toml",
    "observe": "the angle",
    "params": ["field.sources.0.waveform.frequency=10Hz,20Hz", "time.end=100ms,50ms"],
    "paired": True,
    "sets": ["mesh.size=0.5mm"],
    "columns": ["max_angle_arm"],
    "compare": ["max_angle_arm"],
    "compare_by": "time.end",
    "compare_also": ["field.sources.0.waveform.frequency"],
    "figure": ["com_x"],
    "animation": True,
    "windows": ["40Hz=12.5ms", "first_touch=3 ms"],
    "hold": 1e-4,
    "notes": "a note",
    "pending": "why not yet",
    "unresolved": "why not a prediction",
    "uncertainty": "what the numbers' uncertainty is",
    "order": 3,
}


def _write(folder, name, table):
    path = folder / f"{name}.toml"
    path.write_text(tomli_w.dumps(table), encoding="utf-8")
    return path


def test_every_study_of_the_library_round_trips(tmp_path, repo, monkeypatch):
    """Load -> to_table -> TOML -> load gives the same study, for every shipped study."""
    monkeypatch.chdir(repo)
    studies = load_studies()
    assert len(studies) >= 12
    assert [s.order for s in studies] == sorted(s.order for s in studies)
    for study in studies:
        again = load_study(_write(tmp_path, study.ident, to_table(study)))
        assert again == study


def test_a_study_with_every_key_round_trips(tmp_path, repo, monkeypatch):
    monkeypatch.chdir(repo)
    study = load_study(_write(tmp_path, "probe-1", GOOD))
    assert study.ident == "probe-1"
    assert study.params == tuple(GOOD["params"]) and study.paired
    assert to_table(study) == GOOD
    (tmp_path / "again").mkdir()
    assert load_study(_write(tmp_path / "again", "probe-1", to_table(study))) == study


def test_hold_is_a_duration_with_its_unit(tmp_path, repo, monkeypatch):
    monkeypatch.chdir(repo)
    assert load_study(_write(tmp_path, "probe", GOOD | {"hold": "0.1 ms"})).hold == 1e-4
    no_hold = {k: v for k, v in GOOD.items() if k != "hold"}
    assert load_study(_write(tmp_path, "probe", no_hold)).hold == 0.0


def test_text_keys_are_one_paragraph(tmp_path, repo, monkeypatch):
    monkeypatch.chdir(repo)
    table = GOOD | {"notes": "first line\n  second   line\n"}
    assert load_study(_write(tmp_path, "probe", table)).notes == "first line second line"


@pytest.mark.parametrize(
    ("name", "change", "message"),
    [
        ("probe", {"repeat": 2}, "repeat = 2: unknown key; allowed keys are animation, case"),
        ("probe", {"title": None}, "title: missing required key"),
        ("probe", {"paired": "yes"}, "paired = 'yes': must be true or false"),
        ("probe", {"params": []}, "params = []: give at least one NAME=VALUES text"),
        ("probe", {"params": ["time.end"]}, "params[0] = 'time.end': expected NAME=V1,V2"),
        (
            "probe",
            {"params": ["time.end=1s,2s", "mesh.size=1mm"]},
            "params = 'time.end: 2 values, mesh.size: 1 values': paired parameters need lists",
        ),
        ("probe", {"sets": ["time.end"]}, "sets[0] = 'time.end': expected KEY=VALUE"),
        (
            "probe",
            {"compare_by": "mesh.size"},
            "compare_by = 'mesh.size': must name one of params: field.sources.0.waveform.freq",
        ),
        (
            "probe",
            {"compare_by": "", "compare_also": ["time.end"]},
            "compare_also[0] = 'time.end': needs compare_by",
        ),
        (
            "probe",
            {"compare_also": ["time.end"]},
            "compare_also[0] = 'time.end': must name another of params: field.sources.0",
        ),
        ("probe", {"order": -1}, "order = -1: must be >= 0"),
        ("probe", {"hold": "-1 ms"}, "hold = '-1 ms': must be >= 0"),
        ("probe", {"hold": "1 mm"}, "hold = '1 mm': "),
        ("probe", {"windows": ["12.5ms"]}, "windows[0] = '12.5ms': expected LABEL=TIME"),
        ("probe", {"windows": ["a b=1ms"]}, "windows[0] = 'a b=1ms': expected LABEL=TIME"),
        ("probe", {"windows": ["a=1ms", "a=2ms"]}, "windows[1] = 'a=2ms': the label 'a' is"),
        ("probe", {"windows": ["a=2kg"]}, "windows[0] = 'a=2kg': "),
        ("probe", {"windows": ["a=0ms"]}, "windows[0] = 'a=0ms': the time must be > 0"),
        ("probe", {"case": "cases/none.toml"}, "case = 'cases/none.toml': no such case file"),
        ("Probe_1", {}, "(file name) = 'Probe_1': a study id is lowercase letters"),
    ],
)
def test_a_bad_study_file_is_one_line_naming_file_and_key(
    tmp_path, repo, monkeypatch, name, change, message
):
    monkeypatch.chdir(repo)
    table = {k: v for k, v in (GOOD | change).items() if v is not None}
    path = _write(tmp_path, name, table)
    with pytest.raises(CaseError) as info:
        load_study(path)
    text = str(info.value)
    assert "\n" not in text
    assert text.startswith(f"{path}: {message}"), text


def test_toml_syntax_error_and_missing_folder(tmp_path):
    path = tmp_path / "broken.toml"
    path.write_text('title = "unterminated\n', encoding="utf-8")
    with pytest.raises(CaseError, match=rf"^{path}: \(file\): TOML syntax error"):
        load_study(path)
    with pytest.raises(CaseError, match=r"\(folder\): no such studies folder"):
        load_studies(tmp_path / "nowhere")


def test_the_study_keys_are_the_file_keys():
    """Every field but the id is a file key (to_table writes them, the loader accepts them)."""
    names = [f.name for f in dataclasses.fields(Study)]
    assert names[0] == "ident" and set(GOOD) == set(names[1:])
