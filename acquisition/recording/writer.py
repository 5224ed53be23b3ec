"""The trial MCAP writer (layout: :mod:`gaitcap.acquisition.recording.layout`).

Not thread-safe: one thread (the recorder's writer thread) calls it. Writes go to ``<path>.part``;
:meth:`TrialWriter.finish` writes the summary and index, fsyncs and renames to ``<path>``. An OSError
(disk full, file size limit) propagates to the caller, which should call :meth:`TrialWriter.abort`.
"""

from __future__ import annotations

import json
import logging
import os
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from gaitcap.acquisition.recording import layout
from gaitcap.acquisition.recording.foxglove_messages import camera_calibration, schema_data
from gaitcap.reconstruction.calibration_io import rig_from_toml_text
from mcap.writer import CompressionType, Writer

log = logging.getLogger(__name__)

COMPRESSIONS = {"none": CompressionType.NONE, "lz4": CompressionType.LZ4}


@dataclass(frozen=True)
class WriterSettings:
    """Attributes:
    compression: "lz4" or "none" (JPEG barely compresses; zstd costs CPU for ~5 %).
    chunk_size_bytes: image chunk size before it is closed.
    flush_interval_s: at most this much data is held in memory (lost on a crash).
    annotations: also write each keypoint message as ``foxglove.ImageAnnotations`` (the overlay
        Foxglove draws on the images; see :mod:`.foxglove_messages`).
    """

    compression: str = "lz4"
    chunk_size_bytes: int = 4 * 1024 * 1024
    flush_interval_s: float = 1.0
    annotations: bool = True

    def __post_init__(self) -> None:
        if self.compression not in COMPRESSIONS:
            raise ValueError(f"compression: {self.compression!r} is not one of {sorted(COMPRESSIONS)}")
        if self.chunk_size_bytes <= 0 or self.flush_interval_s <= 0:
            raise ValueError("chunk_size_bytes and flush_interval_s must be > 0")


def _flat_metadata(metadata: dict[str, Any]) -> dict[str, str]:
    """MCAP metadata records hold strings: every value JSON-encoded."""
    return {str(k): json.dumps(v) for k, v in metadata.items()}


class TrialWriter:
    """Writes one trial: frames, keypoints, camera status, calibration, metadata, events, summary."""

    def __init__(self, path: str | os.PathLike, settings: WriterSettings = WriterSettings()) -> None:
        self.path = Path(path)
        if self.path.suffix != ".mcap":
            raise ValueError(f"path: a trial recording must end in .mcap, got {self.path}")
        if self.path.exists():
            raise ValueError(f"path: {self.path} already exists (one file per trial)")
        if not self.path.parent.is_dir():
            raise ValueError(f"path: folder {self.path.parent} does not exist")
        self.part_path = self.path.with_name(self.path.name + layout.PART_SUFFIX)
        self.settings = settings
        self._file = open(self.part_path, "wb")
        self._mcap = Writer(
            self._file,
            chunk_size=settings.chunk_size_bytes,
            compression=COMPRESSIONS[settings.compression],
        )
        self._schemas: dict[str, int] = {}
        self._channels: dict[str, int] = {}
        self._keypoints: list[tuple[str, int, int, bytes]] = []
        self._last_flush = time.monotonic()
        self.messages = 0
        self.closed = False

    # -- set-up ---------------------------------------------------------------------------------
    def start(self, *, metadata: dict[str, Any], calibration_toml: str | None = None, time_ns: int) -> None:
        """Header, trial metadata and calibration (as messages, a metadata record and an attachment; and
        one ``foxglove.CameraCalibration`` per camera). ValueError when the calibration is not a rig."""
        self._mcap.start(profile=layout.PROFILE, library="gaitcap")
        self._json(layout.TRIAL_METADATA_TOPIC, metadata, time_ns)
        self._mcap.add_metadata(layout.TRIAL_METADATA_RECORD, _flat_metadata(metadata))
        if calibration_toml is not None:
            rig = rig_from_toml_text(calibration_toml, source="the trial's calibration")
            self._json(layout.CALIBRATION_TOPIC, {"format": "toml", "toml": calibration_toml}, time_ns)
            self._mcap.add_attachment(
                create_time=time_ns,
                log_time=time_ns,
                name=layout.CALIBRATION_ATTACHMENT,
                media_type="application/toml",
                data=calibration_toml.encode(),
            )
            for camera in rig:
                self.add_message(layout.camera_calibration_topic(camera.name),
                                 camera_calibration(camera, time_ns=time_ns), time_ns=time_ns)
        self._mcap.flush()

    def _schema(self, name: str) -> int:
        if name not in self._schemas:
            if name.startswith("foxglove."):
                self._schemas[name] = self._mcap.register_schema(name, "protobuf", schema_data(name))
            else:
                self._schemas[name] = self._mcap.register_schema(name, "jsonschema", layout.json_schema(name))
        return self._schemas[name]

    def _channel(self, topic: str) -> int:
        if topic not in self._channels:
            proto = layout.protobuf_schema_of_topic(topic)
            if proto is not None:
                schema, encoding = self._schema(proto), "protobuf"
            else:
                schema, encoding = self._schema(layout.schema_of_topic(topic)), "json"
            self._channels[topic] = self._mcap.register_channel(topic, encoding, schema)
        return self._channels[topic]

    # -- messages -------------------------------------------------------------------------------
    def _json(self, topic: str, payload: dict[str, Any] | bytes, time_ns: int, sequence: int = 0) -> None:
        data = payload if isinstance(payload, bytes | bytearray) else json.dumps(payload).encode()
        self.add_message(topic, data, time_ns=time_ns, sequence=sequence)

    def add_frame(self, camera: str, image_message: bytes, *, timestamp_ns: int, frame_id: int,
                  receive_ns: int) -> None:
        """A serialised ``foxglove.CompressedImage`` (log time = camera timestamp, sequence = frame id)."""
        channel = self._channel(layout.image_topic(camera))
        self._mcap.add_message(channel, int(timestamp_ns), bytes(image_message), int(receive_ns),
                               int(frame_id) & 0xFFFFFFFF)
        self.messages += 1
        self.maybe_flush()

    def add_message(self, topic: str, data: bytes, *, time_ns: int, sequence: int = 0) -> None:
        """A serialised message on a layout topic (log time = publish time = ``time_ns``)."""
        self._mcap.add_message(self._channel(topic), int(time_ns), bytes(data), int(time_ns), sequence)
        self.messages += 1

    def add_annotations(self, camera: str, annotations: bytes, *, timestamp_ns: int, frame_id: int) -> None:
        """A serialised ``foxglove.ImageAnnotations`` of one frame (log time = the image's camera timestamp)."""
        self.add_message(layout.annotations_topic(camera), annotations, time_ns=timestamp_ns,
                         sequence=int(frame_id) & 0xFFFFFFFF)

    def add_keypoints(self, camera: str, keypoints_json: bytes, *, timestamp_ns: int, frame_id: int) -> None:
        """A ``gaitcap.Keypoints2D`` JSON message; buffered and written in chunks of its own."""
        self._keypoints.append((camera, int(timestamp_ns), int(frame_id), bytes(keypoints_json)))
        self.maybe_flush()

    def add_status(self, camera: str, status: dict[str, Any] | bytes, *, time_ns: int) -> None:
        self._json(layout.status_topic(camera), status, time_ns)

    # -- flushing -------------------------------------------------------------------------------
    def maybe_flush(self, now_s: float | None = None) -> None:
        """Flush when ``flush_interval_s`` has passed since the last flush."""
        now = time.monotonic() if now_s is None else now_s
        if now - self._last_flush >= self.settings.flush_interval_s:
            self.flush()

    def flush(self) -> None:
        """Close the image chunk, write buffered keypoints as a chunk of their own, flush the file."""
        self._mcap.flush()
        if self._keypoints:
            for camera, ts, frame_id, data in self._keypoints:
                self._json(layout.keypoints_topic(camera), data, ts, frame_id & 0xFFFFFFFF)
            self._keypoints.clear()
            self._mcap.flush()
        self._last_flush = time.monotonic()

    def finish(self, summary: dict[str, Any]) -> Path:
        """Write the summary and the index, fsync, rename ``.part`` -> ``.mcap``; returns the final path."""
        self.flush()
        self._mcap.add_metadata(layout.SUMMARY_RECORD, _flat_metadata(summary))
        self._mcap.finish()
        self._file.flush()
        os.fsync(self._file.fileno())
        self._file.close()
        self.closed = True
        os.replace(self.part_path, self.path)
        return self.path

    def abort(self) -> Path:
        """Close after an error without finishing: the ``.part`` file stays for :func:`recover`."""
        if not self.closed:
            self.closed = True
            try:
                self._file.close()
            except OSError as exc:  # the buffered tail may not fit either
                log.warning("closing %s after an error: %s", self.part_path, exc)
        return self.part_path
