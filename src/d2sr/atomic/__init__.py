"""Outputs: written under a temporary name and renamed at the end (a failed or killed run leaves nothing
half-written), and never at the cost of a file d2sr did not make.

The policy, one place for every command:

- ``check_out`` runs before any work: ``--out`` may not be the input, inside it or around it, nor the
  current folder or one of its parents; an existing non-empty output is refused unless ``overwrite``.
  It first ``tidy``-es the output's place: a commit a kill interrupted is finished or rolled back, and
  temporaries a killed run left are removed.
- Every temporary d2sr makes beside an output carries its marker in its name
  (``.<name>.d2sr-<pid>-<random>.tmp``); only such names are ever removed, and only once their process
  has ended.
- A folder d2sr writes carries a manifest (``.d2sr-manifest.json``: the files it made). ``commit``
  replaces only those files when it writes the folder again; every other file and folder in it is kept.
  A non-empty folder without a manifest is never replaced, and a manifest is data: an entry that is not
  a plain relative path inside its folder refuses the whole folder, and nothing is deleted.
- Replacing a folder takes two renames; a journal written before them lets the next run on the same
  output finish the commit or undo it, so a kill at any point loses nothing of the user's.
- A single file is replaced (with ``overwrite``) only when it is recognisably d2sr's (``made_by_d2sr``:
  its header or metadata says so); a user's file of that name is refused.
"""

from __future__ import annotations

from d2sr.atomic.manifest import listed, record_manifest
from d2sr.atomic.naming import CALLER, CSV_HEADERS, MANIFEST, made_by_d2sr, ours, sibling
from d2sr.atomic.oserrors import writing
from d2sr.atomic.placing import (
    atomic_dir,
    atomic_file,
    atomic_write,
    commit,
    discard,
    state,
    temp_for,
    tidy,
)
from d2sr.atomic.policy import check_out
from d2sr.atomic.result import write_result

__all__ = [
    "CALLER",
    "CSV_HEADERS",
    "MANIFEST",
    "atomic_dir",
    "atomic_file",
    "atomic_write",
    "check_out",
    "commit",
    "discard",
    "listed",
    "made_by_d2sr",
    "ours",
    "record_manifest",
    "sibling",
    "state",
    "temp_for",
    "tidy",
    "write_result",
    "writing",
]
