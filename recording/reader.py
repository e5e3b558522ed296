"""Read a ptwl MCAP back with the `mcap` reader: every message decoded, in file order.

A file cut short (the recorder was killed) is read up to its last whole chunk; `complete`
says whether the file was finished (its data-end record was reached). JSON messages decode to
dicts, Foxglove's protobuf messages to protobuf objects built from the schema in the file.
"""

import json
import struct
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mcap.exceptions import McapError
from mcap.records import Channel, DataEnd, Message, Metadata, Schema
from mcap.stream_reader import StreamReader
from mcap_protobuf.decoder import DecoderFactory as ProtobufDecoders


@dataclass(frozen=True)
class Recorded:
    topic: str
    schema: str
    log_time_ns: int
    value: Any  # dict (JSON) or a protobuf message


@dataclass
class Recording:
    path: Path
    messages: list[Recorded] = field(default_factory=list)
    metadata: dict[str, dict[str, str]] = field(default_factory=dict)
    complete: bool = False
    problem: str = ""  # why reading stopped early, when it did

    def on(self, topic: str) -> list[Recorded]:
        return [m for m in self.messages if m.topic == topic]

    def values(self, topic: str) -> list[Any]:
        return [m.value for m in self.messages if m.topic == topic]


def read(path: Path) -> Recording:
    recording = Recording(path)
    schemas: dict[int, Schema] = {}
    channels: dict[int, tuple[Channel, Callable[[bytes], Any]]] = {}
    protobuf = ProtobufDecoders()
    header = False
    with path.open("rb") as stream:
        try:
            for record in StreamReader(stream, skip_magic=False, emit_chunks=False).records:
                header = True  # the first record read is the header (the reader checked the magic)
                if isinstance(record, Schema):
                    schemas[record.id] = record
                elif isinstance(record, Channel):
                    channels[record.id] = (record, _decoder(record, schemas.get(record.schema_id), protobuf))
                elif isinstance(record, Message):
                    channel, decode = channels[record.channel_id]
                    schema = schemas.get(channel.schema_id)
                    recording.messages.append(
                        Recorded(
                            channel.topic, schema.name if schema else "", record.log_time, decode(record.data)
                        )
                    )
                elif isinstance(record, Metadata):
                    recording.metadata[record.name] = dict(record.metadata)
                elif isinstance(record, DataEnd):
                    recording.complete = True
        except (McapError, EOFError, ValueError, struct.error) as err:  # cut short: keep what was whole
            if not header:  # it never began as MCAP does
                raise ValueError(f"{path}: not an MCAP recording ({type(err).__name__})") from None
            recording.problem = f"{type(err).__name__}: {err}".rstrip(": ")
    return recording


def _decoder(channel: Channel, schema: Schema | None, protobuf: ProtobufDecoders) -> Callable[[bytes], Any]:
    if channel.message_encoding == "json":
        return json.loads
    decode = protobuf.decoder_for(channel.message_encoding, schema)
    if decode is None:
        raise McapError(f"no decoder for {channel.topic}: {channel.message_encoding}")
    return decode
