"""The keypoint messages of one camera that reading a recording left out, counted with why."""

from __future__ import annotations

from dataclasses import dataclass, field

STRAY_EXAMPLES = 3  # stray frame ids kept per camera to name them


@dataclass(frozen=True)
class IgnoredKeypoints:
    """Keypoint messages of one camera the reader ignored (a camera with nothing ignored has none).

    Attributes:
        strays: messages with a frame id far outside the recording, or a timestamp far from that of their
            frame id (or outside 0..2**63 ns): nothing was allocated for them.
        stray_frame_ids: the first (in time) of those frame ids, at most :data:`STRAY_EXAMPLES`.
        mistimed: how many of ``strays`` have a frame id of the recording: they were left out for their
            timestamp, not for their id.
        unreadable: {why: messages that could not be read for that reason} (not JSON, a field missing or
            of the wrong kind, people with another number of joints than the others).
    """

    strays: int = 0
    stray_frame_ids: tuple[int, ...] = ()
    mistimed: int = 0
    unreadable: dict[str, int] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not 0 <= self.mistimed <= self.strays:
            raise ValueError(f"ignored keypoints: mistimed {self.mistimed} must be within 0..strays {self.strays}")
        if len(self.stray_frame_ids) > min(self.strays, STRAY_EXAMPLES):
            raise ValueError(f"ignored keypoints: {len(self.stray_frame_ids)} stray frame ids named for "
                             f"{self.strays} strays (at most {STRAY_EXAMPLES})")
        if any(k < 1 for k in self.unreadable.values()):
            raise ValueError(f"ignored keypoints: unreadable counts must be >= 1, got {self.unreadable}")

    @classmethod
    def of(cls, stray_ids: tuple[int, ...] = (), *, mistimed: int = 0,
           unreadable: dict[str, int] | None = None) -> IgnoredKeypoints:
        """From all the stray frame ids (in time order): their count and the first few."""
        return cls(len(stray_ids), tuple(stray_ids[:STRAY_EXAMPLES]), mistimed, dict(unreadable or {}))

    @property
    def unread(self) -> int:
        """Messages that could not be read, whatever why."""
        return sum(self.unreadable.values())

    def to_dict(self) -> dict:
        """JSON-ready: the trial's quality record carries one per camera (``ignored_keypoints``)."""
        return {"strays": self.strays, "stray_frame_ids": list(self.stray_frame_ids), "mistimed": self.mistimed,
                "unreadable": dict(self.unreadable)}
