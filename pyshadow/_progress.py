"""Progress shown on long jobs: a bar over named steps (tqdm)."""
from __future__ import annotations

__all__ = ["Steps"]


class Steps:
    """A progress bar over the steps of a long job, naming the one under way (``progress`` False: none; shown on
    a terminal only, as a CSM build's), titled ``desc``: a choice of CSM (:mod:`pyshadow.csm.choose`), whose pilots,
    predictions, builds and checks of a large mesh take minutes (benchmarks/README.md, bigjob). Entered, it
    gives ``note(step: str)``; closed on leaving, whatever the exit."""

    def __init__(self, progress, desc: str):
        self.bar = None
        if progress:
            from tqdm.auto import tqdm

            self.bar = tqdm(desc=desc, unit="step", disable=None, leave=False)

    def note(self, step: str) -> None:
        if self.bar is not None:
            self.bar.set_postfix_str(step, refresh=False)
            self.bar.update(1)

    def __enter__(self):
        return self.note

    def __exit__(self, *exc):
        if self.bar is not None:
            self.bar.close()
        return False
