"""Subject sets and fast subset matching of messages against subscriptions.

A message is addressed to a set of subjects. A subscription holds a set of subjects and
receives every message whose subject set is a subset of it (MURDOCH section 3). An empty
message subject set therefore reaches every subscription.

`SubjectIndex` keeps, per subject, the ids of the subscriptions that hold it, and answers a
match by intersecting the (few) posting sets of the message's subjects, starting from the
smallest, so the cost depends on the message's subjects, not on the number of subscriptions.
"""

from __future__ import annotations

import re
from collections.abc import Iterable

SubjectSet = frozenset[str]

SUBJECT_PATTERN = re.compile(r"^[a-z0-9][a-z0-9._:/-]{0,63}$")
IDLE = "idle"


class SubjectError(ValueError):
    """A subject name that does not follow the naming rule."""


def check_subject(subject: str) -> str:
    """Return `subject` if it is a valid name, else raise SubjectError saying why."""
    if not isinstance(subject, str) or not SUBJECT_PATTERN.match(subject):
        raise SubjectError(
            f"bad subject {subject!r}: expected 1-64 characters of a-z 0-9 . _ : / -, "
            "starting with a letter or digit"
        )
    return subject


def subject_set(subjects: Iterable[str] | str) -> SubjectSet:
    """Build a validated subject set from an iterable or a comma-separated string."""
    if isinstance(subjects, str):
        items = [part.strip() for part in subjects.split(",") if part.strip()]
    else:
        items = list(subjects)
    return frozenset(check_subject(s) for s in items)


def matches(message_subjects: SubjectSet, subscription: SubjectSet) -> bool:
    """True when a message addressed to `message_subjects` reaches `subscription`."""
    return message_subjects <= subscription


class SubjectIndex:
    """Subscription id -> subject set, with subset matching by posting-set intersection."""

    def __init__(self) -> None:
        self._subjects: dict[int, SubjectSet] = {}
        self._postings: dict[str, set[int]] = {}

    def __len__(self) -> int:
        return len(self._subjects)

    def __contains__(self, key: int) -> bool:
        return key in self._subjects

    def subjects_of(self, key: int) -> SubjectSet:
        return self._subjects[key]

    def set(self, key: int, subjects: SubjectSet) -> None:
        """Add or replace subscription `key`'s subjects."""
        self.remove(key)
        self._subjects[key] = subjects
        for subject in subjects:
            self._postings.setdefault(subject, set()).add(key)

    def remove(self, key: int) -> None:
        old = self._subjects.pop(key, None)
        if old is None:
            return
        for subject in old:
            posting = self._postings.get(subject)
            if posting is not None:
                posting.discard(key)
                if not posting:
                    del self._postings[subject]

    def match(self, message_subjects: SubjectSet) -> list[int]:
        """Ids of subscriptions whose subjects include all of `message_subjects`, sorted."""
        if not message_subjects:
            return sorted(self._subjects)
        postings = []
        for subject in message_subjects:
            posting = self._postings.get(subject)
            if not posting:
                return []
            postings.append(posting)
        postings.sort(key=len)
        result = set(postings[0])
        for posting in postings[1:]:
            result &= posting
            if not result:
                return []
        return sorted(result)
