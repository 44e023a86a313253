"""Bad-input cases, `montecarlo` and the study folder's own files.

See tests/test_bad_input.py, which runs every case.
"""

from __future__ import annotations

import json

# (id, files to write {name: text or bytes or callable(path)}, argv with {d} for the case folder,
#  expected exit status, a fragment the message must contain)
CASES = [
    # montecarlo
    ("mc-trials-zero", {}, ["montecarlo", "belt-stage", "--trials", "0"], 2, "--trials"),
    (  # a certificate for no cluster: the local pool would run and the file be ignored
        "mc-tls-without-a-scheduler",
        {},
        ["montecarlo", "stewart", "--trials", "2", "--tls-ca-file", "{d}/ca.pem"],
        2,
        "--tls-* files are for a Dask cluster's --scheduler",
    ),
    (  # a study labelled render whose trials were analytic
        "mc-render-without-a-camera",
        {},
        ["montecarlo", "arm-cmm", "--trials", "2", "--fidelity", "render"],
        2,
        "--fidelity render applies to the scenarios with a camera (belt-stage, vision-stage)",
    ),
    ("mc-trials-negative", {}, ["montecarlo", "belt-stage", "--trials", "-3"], 2, "--trials"),
    ("mc-trials-missing", {}, ["montecarlo", "belt-stage"], 2, "--trials"),
    ("mc-trials-huge", {}, ["montecarlo", "belt-stage", "--trials", "1000000000"], 2, "--trials"),
    (
        "mc-workers-zero",
        {},
        ["montecarlo", "belt-stage", "--trials", "2", "--workers", "0"],
        2,
        "--workers",
    ),
    (
        "mc-workers-beyond-the-machine",
        {},
        ["montecarlo", "belt-stage", "--trials", "2", "--workers", "100000"],
        2,
        "local workers on this machine",
    ),
    (
        "mc-workers-negative",
        {},
        ["montecarlo", "belt-stage", "--trials", "2", "--workers", "-2"],
        2,
        "--workers",
    ),
    (
        "mc-scheduler-not-url",
        {},
        ["montecarlo", "belt-stage", "--trials", "2", "--scheduler", "notaurl", "--out", "{d}/o"],
        2,
        "--scheduler",
    ),
    ("mc-unknown-scenario", {}, ["montecarlo", "no-such", "--trials", "2"], 2, "unknown scenario"),
    (
        "mc-arm-on-stage",
        {},
        ["montecarlo", "belt-stage", "--trials", "2", "--arm", "ur10"],
        2,
        "--arm applies to arm-cmm",
    ),
    (
        "mc-out-is-file",
        {"f.txt": "x"},
        ["montecarlo", "belt-stage", "--trials", "2", "--out", "{d}/f.txt"],
        2,
        "is a file",
    ),
    (
        "mc-corrupt-journal",
        {
            "o/study.json": json.dumps(
                {"scenario": "belt-stage", "seed": 0, "fidelity": "analytic"}
            )
            + "\n",
            "o/trials.jsonl": 'garbage\n{"no": 1}\n[1, 2]\n',
        },
        ["montecarlo", "belt-stage", "--trials", "2", "--out", "{d}/o"],
        2,
        "trials.jsonl",
    ),
    (
        "mc-foreign-journal",
        {"o/trials.jsonl": json.dumps({"trial": 0, "scenario": "stewart"}) + "\n"},
        ["montecarlo", "belt-stage", "--trials", "2", "--out", "{d}/o"],
        2,
        "trials.jsonl",
    ),
    (  # study.json deleted, the journal another seed's: its trials are not this study's
        "mc-journal-of-another-seed",
        {"o/trials.jsonl": json.dumps({"trial": 0, "seed": 123, "ok": True, "error": None}) + "\n"},
        ["montecarlo", "belt-stage", "--trials", "2", "--seed", "5", "--out", "{d}/o"],
        2,
        "trial 0 was run by another --seed, not this study's (--seed 5)",
    ),
    (  # the journal of `--seed 0` (trial 0's own seed 2968811710): named by the --seed typed
        "mc-journal-of-seed-0",
        {"o/trials.jsonl": json.dumps({"trial": 0, "seed": 2968811710, "ok": True}) + "\n"},
        ["montecarlo", "belt-stage", "--trials", "2", "--seed", "1", "--out", "{d}/o"],
        2,
        "trial 0 was run by a study with --seed 0, not this study's (--seed 1)",
    ),
    (
        "mc-corrupt-study",
        {"o/study.json": "{not json"},
        ["montecarlo", "belt-stage", "--trials", "2", "--out", "{d}/o"],
        2,
        "study.json",
    ),
    (
        "mc-other-study",
        {"o/study.json": json.dumps({"scenario": "stewart", "seed": 0, "fidelity": "analytic"})},
        ["montecarlo", "belt-stage", "--trials", "2", "--out", "{d}/o"],
        2,
        "different study",
    ),
]
