"""Patient (subject) ids: pseudonyms only. An id must match the configured pattern (``GAITCAP_SUBJECT_ID_PATTERN``,
default: 1-32 letters, digits, ``_ . -``) and must not look like a name or carry a date (of birth); ids are
compared case-insensitively (stored upper case: ``p0042`` is ``P0042``)."""

from __future__ import annotations

import re

DEFAULT_PATTERN = r"[A-Za-z0-9][A-Za-z0-9_.\-]{0,31}"
_DATE = re.compile(r"(19|20)\d\d[-_.]?(0[1-9]|1[0-2])[-_.]?(0[1-9]|[12]\d|3[01])"
                   r"|(0[1-9]|[12]\d|3[01])[-_.]?(0[1-9]|1[0-2])[-_.]?(19|20)?\d\d(?!\d)")
_NAME = re.compile(r"[A-Za-z]{3,}[-_. ]+[A-Za-z]{3,}")


def check_subject_id(value: str, pattern: str = DEFAULT_PATTERN) -> str:
    """The canonical (upper-case) id; ValueError saying why a name-like or malformed id is refused."""
    if not isinstance(value, str) or not re.fullmatch(pattern, value):
        if pattern == DEFAULT_PATTERN:
            raise ValueError("subject_id: must match the ID rules: 1-32 letters, digits, '.', '_' or '-', starting "
                             "with a letter or digit (a pseudonym such as P0042)")
        raise ValueError(f"subject_id: must match the clinic's pattern {pattern} (a pseudonym such as P0042)")
    if _DATE.search(value):
        raise ValueError("subject_id: looks like it contains a date (of birth?); use a pseudonym such as P0042")
    if _NAME.search(value):
        raise ValueError("subject_id: looks like a name; use a pseudonym such as P0042")
    return value.upper()
