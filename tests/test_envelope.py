"""One result contract: every command's --json is the envelope; every kind is stored, read back
and rendered by the report (a generic section where a kind has no special one)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from inertest.cli import main
from inertest.procedures import REGISTRY
from inertest.report.html import page
from inertest.report.sections import envelope_sections
from inertest.results import ENVELOPE_KEYS, OPTIONAL_KEYS, SCHEMA_VERSION, envelope
from inertest.store import HistoryStore, RunRecord
from procedure_examples import EXAMPLES


def check_envelope(doc: dict, kind: str) -> None:
    """The layout every result shares (results.envelope), with units beside numbers."""
    assert list(doc) == [k for k in ENVELOPE_KEYS if k in doc]
    assert set(ENVELOPE_KEYS) - OPTIONAL_KEYS <= set(doc)
    if "test" in doc:  # the optional identity block (quality.lab.identity_block), after instrument
        assert list(doc).index("test") == list(doc).index("instrument") + 1
        assert {"operator", "date", "software_version", "data_sha256", "equipment",
                "environment"} <= set(doc["test"])
    assert doc["kind"] == kind and doc["schema_version"] == SCHEMA_VERSION
    assert isinstance(doc["result"], dict)
    assert isinstance(doc["checks"], list) and all("name" in c and "verdict" in c
                                                   for c in doc["checks"])
    assert isinstance(doc["messages"], list) and all(isinstance(m, str) for m in doc["messages"])
    ident = doc["identification"]
    if ident is not None:
        for name, e in ident.get("coefficients", {}).items():
            assert set(e) >= {"value", "std", "unit"}, name
            assert e["std"] is None or (math.isfinite(e["std"]) and e["std"] >= 0), name


def _json(capsys) -> dict:
    return json.loads(capsys.readouterr().out)


def test_registry_names_every_example():
    assert set(EXAMPLES) == set(REGISTRY)


@pytest.mark.parametrize("kind", sorted(EXAMPLES))
def test_fit_json_is_the_envelope(kind, examples_dir, tmp_path, capsys):
    folder, truth, noise = EXAMPLES[kind]
    plan = examples_dir / folder / "plan.toml"
    data = tmp_path / "data.parquet"
    assert main(["simulate", str(plan), "--truth", str(examples_dir / folder / truth),
                 "-o", str(data), "--noise", str(noise), "--seed", "3"]) == 0
    capsys.readouterr()
    assert main(["fit", str(plan), str(data), "--json", "--no-store"]) == 0
    doc = _json(capsys)
    check_envelope(doc, kind)
    assert doc["identification"]["coefficients"]
    assert doc["instrument"]["serial"]  # the example plans name their instrument
    # The same document is what the store keeps and gives back.
    store = HistoryStore(str(tmp_path / "h.db"))
    try:
        rec = RunRecord.from_result(doc, serial="SN-1", instrument_kind="x", plan_text="",
                                    data_sha256="0" * 64, software_version="t")
        store.add(rec)
        back = store.runs("SN-1")[0]
    finally:
        store.close()
    # ... with the time it was filed, which a run not stored has not got
    want = json.loads(json.dumps(doc))
    want["test"]["filed_at"] = back.filed_at.isoformat(timespec="seconds")
    assert back.procedure == kind and back.result == want
    assert {e.name for e in back.estimates} >= set(doc["identification"]["coefficients"])


def _analysis_documents(tmp_path: Path, examples_dir: Path, capsys) -> dict[str, dict]:
    """The --json of every analysis command on small inputs."""
    docs: dict[str, dict] = {}
    rng = np.random.default_rng(1)
    np.save(tmp_path / "g.npy", rng.normal(0, 1e-4, 20000))
    assert main(["allan", str(tmp_path / "g.npy"), "--rate", "50", "--json"]) == 0
    docs["allan"] = _json(capsys)
    assert main(["ins-errors", "--latitude", "39", "--hours", "2", "--step", "600",
                 "--gyro-drift-deg-h", "0.01,0.01,0.01", "--json"]) == 0
    docs["ins-errors"] = _json(capsys)
    assert main(["modulation", "component", "--stator-hz", "1", "--sample-hz", "400",
                 "--json"]) == 0
    docs["modulation-component"] = _json(capsys)
    assert main(["modulation", "system", "--scheme", "single-axis", "--hours", "1",
                 "--json"]) == 0
    docs["modulation-system"] = _json(capsys)
    cycles = tmp_path / "cycles.parquet"
    assert main(["thermal", "simulate", "-o", str(cycles), "--cycles", "3", "--seed", "1"]) == 0
    capsys.readouterr()
    assert main(["thermal", "fit", str(cycles), "--json", "--max-iter", "300"]) == 0
    docs["thermal-compensation"] = _json(capsys)
    assert main(["centrifuge-study", str(examples_dir / "centrifuge" / "study.toml"),
                 "--json"]) == 0
    docs["centrifuge-study"] = _json(capsys)
    return docs


@pytest.mark.slow
def test_every_analysis_json_is_the_envelope_stored_and_reported(tmp_path, examples_dir,
                                                                 capsys):
    docs = _analysis_documents(tmp_path, examples_dir, capsys)
    store = HistoryStore(str(tmp_path / "h.db"))
    try:
        for kind, doc in docs.items():
            check_envelope(doc, kind)
            store.add(RunRecord.from_result(doc, serial="LAB-1", instrument_kind="imu",
                                            plan_text="", data_sha256=kind.ljust(64, "0"),
                                            software_version="t"))
            html = page(kind, envelope_sections(doc, title="Result"))
            assert f"({kind})" in html and ("<table" in html or "<pre" in html)
        runs = store.runs("LAB-1")
    finally:
        store.close()
    back = {r.procedure: r.result for r in runs}
    want = json.loads(json.dumps(docs))
    for r in runs:  # a run with a test block comes back with the time it was filed
        if isinstance(want[r.procedure].get("test"), dict):
            want[r.procedure]["test"]["filed_at"] = r.filed_at.isoformat(timespec="seconds")
    assert back == want


def test_optional_blocks_take_their_place_and_only_when_given():
    plain = envelope("polar-tumble", messages=["m"])
    assert list(plain) == [k for k in ENVELOPE_KEYS if k not in OPTIONAL_KEYS]
    budget = {"quantities": {"DI": {"value": 0.1, "unit": "deg/h/g", "expanded": 0.02}},
              "assumptions": ["sources independent"]}
    verdicts = {"spec": "s", "rule": "r", "verdicts": [{"quantity": "DI", "verdict": "pass"}]}
    doc = envelope("polar-tumble", test={"operator": "A"}, uncertainty_budget=budget,
                   conformance=verdicts)
    assert list(doc) == list(ENVELOPE_KEYS)
    assert doc["uncertainty_budget"] == budget and doc["conformance"] == verdicts
    assert json.loads(json.dumps(doc)) == doc


def test_envelope_lifts_the_message_of_a_failed_check():
    """A model that does not fit says so in ``messages`` too (issue 15 review), each once."""
    bad = {"name": "noise model fit", "verdict": "model does not fit", "message": "misfit: why"}
    good = {"name": "noise model fit", "verdict": "consistent", "message": None}
    doc = envelope("polar-tumble", checks=[bad, good], messages=["a note", "misfit: why"])
    assert doc["messages"] == ["a note", "misfit: why"]
    assert envelope("polar-tumble", checks=[bad, good])["messages"] == ["misfit: why"]
    assert envelope("polar-tumble", checks=[good])["messages"] == []


def test_one_schema_check_reads_every_envelope_back(tmp_path, capsys):
    """apply (and nav-calibrate --initial) and the store read an envelope back through
    results.read_envelope: another schema version is refused with what to do."""
    import json

    from inertest.cli import main
    from inertest.errors import InputError
    from inertest.results import SCHEMA_VERSION, read_envelope

    doc = {"kind": "ferraris", "schema_version": SCHEMA_VERSION + 1, "result": {}}
    with pytest.raises(InputError, match="schema_version 3; this inertest reads version 2"):
        read_envelope(doc, source="x")
    with pytest.raises(InputError, match="not an inertest result"):
        read_envelope([1, 2], source="x")
    cal = tmp_path / "cal.json"
    cal.write_text(json.dumps(doc))
    data = tmp_path / "d.csv"
    data.write_text("acc_x,acc_y,acc_z\n1,2,3\n")
    assert main(["apply", str(cal), str(data), "-o", str(tmp_path / "o.csv")]) == 2
    err = capsys.readouterr().err
    assert "schema_version 3" in err and "refit the data" in err
    assert not (tmp_path / "o.csv").exists()
