"""What every blinded recording shares: the recording for ``discover`` and its sealed manifest."""

from __future__ import annotations

import json
from pathlib import Path


def write_blinded(out_dir: Path, name: str, recording, manifest: dict) -> Path:
    """Write a blinded recording for ``discover`` and its truth sealed beside it.

    Parameters
    ----------
    out_dir : Path
        The folder (made if missing).
    name : str
        The files' stem: ``name``.csv (the recording, its docs/formats.md format) and
        ``name``.manifest.json (the manifest).
    recording : StageRecording, ArmRecording, ScannerRecording or StewartRecording
        Anything with ``to_csv(path)``.
    manifest : dict
        The sealed truth, JSON-serialisable.

    Returns
    -------
    Path
        The recording's CSV.
    """
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / f"{name}.csv"
    recording.to_csv(path)
    (out_dir / f"{name}.manifest.json").write_text(json.dumps(manifest, indent=1) + "\n")
    return path
