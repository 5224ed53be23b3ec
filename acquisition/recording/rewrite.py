"""Write scanned MCAP messages into a new, valid MCAP (used by crash recovery)."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING

from gaitcap.acquisition.fileio import atomic_path
from gaitcap.acquisition.recording import layout
from mcap.records import Message
from mcap.writer import CompressionType, Writer

if TYPE_CHECKING:
    from gaitcap.acquisition.recording.reader import ScanState


def rewrite_scanned(messages: Iterator[tuple[str, Message]], state: ScanState, target: Path) -> dict[str, int]:
    """Copy (topic, message) pairs with their schemas and channels into ``target`` (temp + rename).

    Returns message counts per topic. Metadata records and attachments found are copied too, and a
    ``summary`` record marks the file as recovered.
    """
    counts: dict[str, int] = {}
    schema_ids: dict[int, int] = {}
    channel_ids: dict[int, int] = {}
    with atomic_path(target, fsync=True) as tmp, open(tmp, "wb") as f:
        writer = Writer(f, compression=CompressionType.LZ4)
        writer.start(profile=layout.PROFILE, library="gaitcap-recover")
        for topic, msg in messages:
            if msg.channel_id not in channel_ids:
                channel = state.channels[msg.channel_id]
                sid = 0
                if channel.schema_id:
                    if channel.schema_id not in schema_ids:
                        s = state.schemas[channel.schema_id]
                        schema_ids[channel.schema_id] = writer.register_schema(s.name, s.encoding, s.data)
                    sid = schema_ids[channel.schema_id]
                channel_ids[msg.channel_id] = writer.register_channel(topic, channel.message_encoding, sid)
            writer.add_message(channel_ids[msg.channel_id], msg.log_time, msg.data, msg.publish_time, msg.sequence)
            counts[topic] = counts.get(topic, 0) + 1
        for name, data in state.attachments.items():
            writer.add_attachment(0, 0, name, "application/octet-stream", data)
        for name, meta in state.metadata.items():
            if name != layout.SUMMARY_RECORD:
                writer.add_metadata(name, meta)
        summary = {"recovered": True, "source": str(state.path), "corrupt_chunks": state.corrupt_chunks,
                   "cut": state.error, "messages": counts}
        writer.add_metadata(layout.SUMMARY_RECORD, {k: json.dumps(v) for k, v in summary.items()})
        writer.finish()
    return counts
