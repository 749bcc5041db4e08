"""The output folder of a run: what a run writes there, and when it may write there.

A run refuses a folder that holds the outputs of a previous run (its
history, field series, pictures or checkpoint: :data:`RUN_OUTPUTS`) unless
told to continue it (``--resume``, which needs the checkpoint) or to
replace it (``--overwrite``, which deletes those outputs and nothing
else). Other files in the folder (``magfem field``'s outputs, the user's
notes) are left alone and do not count.
"""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

from magfem.config import CaseError

__all__ = ["CHECKPOINT", "RUN_OUTPUTS", "prepare_run_directory", "previous_run_outputs"]

CHECKPOINT = "checkpoint"
"""The checkpoint folder of a run (:mod:`magfem.mechanics.checkpoint`)."""

RUN_OUTPUTS = (
    "history.csv",
    "displacement.bp",
    "displacement.*.bp",
    "displacement.pvd",
    "displacement",
    "snapshots",
    "motion.gif",
    "angle.png",
    CHECKPOINT,
    f"{CHECKPOINT}.tmp",
    f"{CHECKPOINT}.old",
)
"""Names (glob patterns) of what a run writes, the resolved case aside (``magfem field``
writes one too)."""


def previous_run_outputs(outdir: Path) -> list[Path]:
    """The outputs of a run found in ``outdir``, sorted (empty when there are none)."""
    outdir = Path(outdir)
    if not outdir.is_dir():
        return []
    found = {p for pattern in RUN_OUTPUTS for p in outdir.glob(pattern)}
    return sorted(found)


def prepare_run_directory(outdir: Path, *, resume: bool = False, overwrite: bool = False) -> Path:
    """Make ``outdir`` ready for a run (call on one process: rank 0).

    Args:
        resume: continue the run whose checkpoint is in ``outdir``.
        overwrite: delete the outputs of a previous run first.

    Raises:
        CaseError: ``outdir`` holds a previous run and neither flag is given;
            ``resume`` without a checkpoint; both flags.
        OSError: ``outdir`` is a file, or cannot be created or written.
    """
    outdir = Path(outdir)
    if resume and overwrite:
        raise CaseError("--overwrite", True, "give --resume or --overwrite, not both")
    if resume:
        if not (outdir / CHECKPOINT).is_dir() and not (outdir / f"{CHECKPOINT}.old").is_dir():
            raise CaseError(
                "--resume",
                str(outdir),
                "no checkpoint in this folder (a run writes one when it is stopped by a signal, "
                "and every [output] checkpoint_every steps or checkpoint_interval)",
            )
    else:
        previous = previous_run_outputs(outdir)
        if previous and not overwrite:
            raise CaseError(
                "--out",
                str(outdir),
                f"holds the outputs of a previous run ({previous[0].name}, ...): "
                "--resume DIR continues it, --overwrite replaces it",
            )
        for path in previous:
            if path.is_dir() and not path.is_symlink():
                shutil.rmtree(path)
            else:
                path.unlink()
    outdir.mkdir(parents=True, exist_ok=True)
    with tempfile.NamedTemporaryFile(dir=outdir, prefix=".magfem-write-test-"):
        pass  # a folder we cannot write into fails here, not in the middle of the run
    return outdir
