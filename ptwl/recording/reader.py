"""Read a ptwl MCAP back with the `mcap` reader, as a stream: one chunk in memory at a time.

`Scan` walks a file once, in file order, and yields its messages decoded (JSON to dicts,
Foxglove's protobuf to protobuf objects built from the schema in the file); messages on topics
nobody asked for are counted, never decoded. `read()` keeps every message in a list, for tests
and small files; `ptwl report` and `ptwl replay` stream.

A file cut short (the recorder was killed) is read up to its last whole chunk; `complete` says
whether the file was finished (its data-end record was reached). A file that is not what our
writer makes, or what any sane writer makes, stops with a `RecordingError` naming the file, the
place and the problem, before it can take the memory or the stack: every bound is below.
"""

import json
import re
import struct
from collections.abc import Callable, Collection, Iterator
from dataclasses import dataclass, field
from io import BytesIO
from pathlib import Path
from typing import IO, Any, BinaryIO, cast

import lz4.frame
import zstandard
from mcap.data_stream import ReadDataStream
from mcap.exceptions import McapError, RecordLengthLimitExceeded
from mcap.opcode import Opcode
from mcap.records import Channel, Chunk, DataEnd, Message, Metadata, Schema
from mcap.stream_reader import StreamReader
from mcap_protobuf.decoder import DecoderFactory as ProtobufDecoders
from ptwl_config import PtwlError

# Our writer closes a chunk at 1 MiB (the Foxglove SDK's chunk_size) or 1 s of log time, so a
# chunk holds ~1 MiB plus at most one message; one scene's geometry is ~0.1 MiB.
MAX_CHUNK_BYTES = 64 * 2**20  # [B] decompressed size one chunk may declare (checked before it is)
# zstd and lz4 may grow incompressible data by < 1/128; any other record is smaller still.
MAX_RECORD_BYTES = MAX_CHUNK_BYTES + MAX_CHUNK_BYTES // 128  # [B] one record as stored
# A 1-hour session decompresses to ~0.4 GiB; 4 GiB bounds how long a file keeps a reader busy.
MAX_TOTAL_BYTES = 4 * 2**30  # [B] all chunks of one file, decompressed
MAX_JSON_DEPTH = 64  # nesting of one JSON message; ours nest 5 deep (geometry)
# One JSON message decoded can take ~20x its text in Python objects ("[[],[],...]"): ours are at
# most ~0.1 MiB (a scene's geometry), so 4 MiB (<= ~90 MB decoded) leaves a margin of 40.
MAX_JSON_BYTES = 4 * 2**20


class RecordingError(PtwlError, ValueError):
    """A file that no writer of ours made: named, with the place, as one line."""


@dataclass(frozen=True)
class Recorded:
    topic: str
    schema: str
    log_time_ns: int
    value: Any  # dict (JSON) or a protobuf message


@dataclass(frozen=True)
class Located:
    """A message not yet decoded, and where it is: the top-level record (a chunk, or the
    message itself) at byte `offset`, and its place among that record's messages."""

    number: int  # 1-based, in file order: how an error names it
    offset: int
    ordinal: int
    channel: Channel
    message: Message


@dataclass
class Recording:
    path: Path
    messages: list[Recorded] = field(default_factory=list)
    metadata: dict[str, dict[str, str]] = field(default_factory=dict)
    complete: bool = False
    problem: str = ""  # why reading stopped early, when it did
    count: int = 0  # messages in the file, on every topic

    def on(self, topic: str) -> list[Recorded]:
        return [m for m in self.messages if m.topic == topic]

    def values(self, topic: str) -> list[Any]:
        return [m.value for m in self.messages if m.topic == topic]


def read(path: Path, topics: Collection[str] | None = None) -> Recording:
    """Every message (on `topics`, if given) decoded into memory: for tests and small files."""
    scan = Scan(path, topics)
    messages = list(scan)
    return Recording(path, messages, scan.metadata, scan.complete, scan.problem, scan.count)


class Scan:
    """One pass over a file. Iterate it for the messages on `topics` (every topic if None);
    `metadata`, `complete`, `problem` and `count` are whole once the iteration ends."""

    def __init__(self, path: Path, topics: Collection[str] | None = None) -> None:
        self.path = path
        self.topics = None if topics is None else frozenset(topics)
        self.metadata: dict[str, dict[str, str]] = {}
        self.complete = False
        self.problem = ""
        self.count = 0
        self.decompressed_bytes = 0
        self.schemas: dict[int, Schema] = {}
        self.channels: dict[int, Channel] = {}
        self._decoders: dict[int, Callable[[bytes], Any]] = {}
        self._protobuf = ProtobufDecoders()

    def __iter__(self) -> Iterator[Recorded]:
        for found in self.located():
            yield self.decode(found)

    def located(self) -> Iterator[Located]:
        """The messages on `topics`, undecoded, with where each is in the file."""
        with self.path.open("rb") as stream:
            for offset, record in self._top_level(stream):
                if isinstance(record, Chunk):
                    inner: Iterator[Any] = self._chunk_records(record, offset)
                else:
                    inner = iter((record,))
                ordinal = 0
                for item in inner:
                    if isinstance(item, Message):
                        self.count += 1
                        channel = self._channel(item)
                        if self.topics is None or channel.topic in self.topics:
                            yield Located(self.count, offset, ordinal, channel, item)
                        ordinal += 1
                    else:
                        self._define(item)

    def reread(self, offset: int) -> list[tuple[Channel, Message]]:
        """Every message in the record at `offset` (a chunk, or one message), indexed by its
        ordinal there, read again with the same bounds: a replay's seek."""
        found: list[tuple[Channel, Message]] = []
        with self.path.open("rb") as stream:
            stream.seek(offset)
            opcode, length = struct.unpack("<BQ", _exactly(stream, 9, self.path))
            if length > MAX_RECORD_BYTES:
                raise RecordingError(f"{self.path}: record at byte {offset} is {length} B, over the bound")
            body = ReadDataStream(BytesIO(_exactly(stream, length, self.path)))
            if opcode == Opcode.CHUNK:
                records: Iterator[Any] = self._chunk_records(Chunk.read(body), offset, counted=False)
            elif opcode == Opcode.MESSAGE:
                records = iter((Message.read(body, length),))
            else:
                raise RecordingError(f"{self.path}: no chunk or message at byte {offset}")
            for item in records:
                if isinstance(item, Message):
                    found.append((self._channel(item), item))
        return found

    def decode(self, found: Located) -> Recorded:
        return self.decode_message(found.channel, found.message, found.number)

    def decode_message(self, channel: Channel, message: Message, number: int | None = None) -> Recorded:
        schema = self.schemas.get(channel.schema_id)
        where = f"message {number} on {channel.topic}" if number else f"a message on {channel.topic}"
        decode = self._decoders.get(channel.id)
        if decode is None:
            decode = self._decoders[channel.id] = self._decoder(channel, schema, where)
        try:
            value = decode(bytes(message.data))  # a view into its chunk: bytes for the decoders
        except RecordingError as err:
            raise RecordingError(f"{self.path}: {where}: {err}") from None
        except Exception as err:  # protobuf's and json's many errors: all the file's fault
            raise RecordingError(f"{self.path}: {where}: cannot be decoded ({type(err).__name__})") from None
        return Recorded(channel.topic, schema.name if schema else "", message.log_time, value)

    # ------------------------------------------------------------------ the file
    def _top_level(self, stream: BinaryIO) -> Iterator[tuple[int, Any]]:
        """The file's records with the offset each starts at, chunks still compressed; a file
        cut short ends quietly (`problem` says where) after its last whole record."""
        bounded = cast(IO[bytes], _Bounded(stream))
        reader = _Reader(bounded, emit_chunks=True, record_size_limit=MAX_RECORD_BYTES)
        records = reader.records
        header = False
        while True:
            try:
                record = next(records)
            except StopIteration:
                return
            except RecordLengthLimitExceeded as err:  # raised right after the record's length
                offset = stream.tell() - 9
                if not self._past_the_end(offset):  # whole in the file, and over the bound
                    raise RecordingError(f"{self.path}: record at byte {offset}: {err}") from None
                # A record the file does not hold: a chunk the writer was killed in the middle
                # of (it declares 2^64 - 1 bytes until it is finished).
                self.problem = f"the record at byte {offset} runs past the end of the file"
                return
            except _Oversize as err:
                raise RecordingError(f"{self.path}: record at byte {reader.record_offset}: {err}") from None
            except (McapError, EOFError, ValueError, struct.error) as err:  # cut short
                if not header:  # it never began as MCAP does
                    name = type(err).__name__
                    raise RecordingError(f"{self.path}: not an MCAP recording ({name})") from None
                self.problem = f"{type(err).__name__}: {err}".rstrip(": ")
                return
            offset = reader.record_offset
            header = True  # the first record read is the header (the reader checked the magic)
            if isinstance(record, Metadata):
                self.metadata[record.name] = dict(record.metadata)
            elif isinstance(record, DataEnd):
                self.complete = True
            yield offset, record

    def _past_the_end(self, offset: int) -> bool:
        with self.path.open("rb") as stream:
            stream.seek(offset)
            head = stream.read(9)
            end = stream.seek(0, 2)
        return len(head) < 9 or offset + 9 + struct.unpack("<BQ", head)[1] > end

    def _chunk_records(self, chunk: Chunk, offset: int, counted: bool = True) -> Iterator[Any]:
        """A chunk's schemas, channels and messages, one at a time, from a decompression
        bounded before it starts."""
        where = f"{self.path}: chunk at byte {offset}"
        size = chunk.uncompressed_size
        if size > MAX_CHUNK_BYTES:
            raise RecordingError(f"{where}: declares {size} B decompressed, over {MAX_CHUNK_BYTES} B")
        if counted:
            self.decompressed_bytes += size
            if self.decompressed_bytes > MAX_TOTAL_BYTES:
                raise RecordingError(f"{where}: the file decompresses to over {MAX_TOTAL_BYTES} B")
        data = _decompress(chunk, where)
        view = memoryview(data)
        # The record layout (opcode, length, then the body) read in place with struct, not by
        # mcap's ReadDataStream a field at a time: 5x faster over an hour's 1.4 M messages.
        # Schema and channel records, a few a file, are mcap's own parsers on their bytes.
        position, end = 0, len(data)
        while position < end:
            if end - position < _RECORD.size:
                raise RecordingError(f"{where}: a record runs past the chunk's end")
            opcode, length = _RECORD.unpack_from(data, position)
            body, position = position + _RECORD.size, position + _RECORD.size + length
            if position > end:
                raise RecordingError(f"{where}: a record runs past the chunk's end")
            if opcode == Opcode.MESSAGE:
                if length < _MESSAGE.size:
                    raise RecordingError(f"{where}: a message record of {length} B, under its header")
                channel_id, sequence, log_time, publish_time = _MESSAGE.unpack_from(data, body)
                payload = cast(bytes, view[body + _MESSAGE.size : position])  # decode() copies it out
                yield Message(channel_id, log_time, payload, publish_time, sequence)
            elif opcode in (Opcode.CHANNEL, Opcode.SCHEMA):
                record = ReadDataStream(BytesIO(view[body:position]))
                try:
                    yield Channel.read(record) if opcode == Opcode.CHANNEL else Schema.read(record)
                except (McapError, struct.error, UnicodeDecodeError) as err:
                    raise RecordingError(f"{where}: a malformed record ({type(err).__name__})") from None
            elif opcode == 0:  # reserved: a run of zero bytes (a bomb's padding) is no MCAP
                raise RecordingError(f"{where}: a record with opcode 0, which MCAP reserves")
            # other opcodes: MCAP says skip what you do not know

    def _define(self, record: Any) -> None:
        if isinstance(record, Schema):
            self.schemas[record.id] = record
        elif isinstance(record, Channel):
            self.channels[record.id] = record
            self._decoders.pop(record.id, None)

    def _channel(self, message: Message) -> Channel:
        channel = self.channels.get(message.channel_id)
        if channel is None:
            raise RecordingError(
                f"{self.path}: message {self.count} is on channel {message.channel_id}, "
                "which no channel record before it defines"
            )
        return channel

    def _decoder(self, channel: Channel, schema: Schema | None, where: str) -> Callable[[bytes], Any]:
        if channel.message_encoding == "json":
            return decode_json
        try:
            decode = self._protobuf.decoder_for(channel.message_encoding, schema)
        except Exception as err:  # a schema that is no descriptor set
            name = type(err).__name__
            raise RecordingError(f"{self.path}: {where}: its schema is unreadable ({name})") from None
        if decode is None:
            raise RecordingError(
                f"{self.path}: {where}: no decoder for encoding {channel.message_encoding!r}"
                + ("" if schema else f" (schema {channel.schema_id} is not in the file)")
            )
        return decode


def _decompress(chunk: Chunk, where: str) -> bytes:
    """Exactly the declared size, or an error: never more than it, so a chunk that lies about
    its size (a bomb) costs at most MAX_CHUNK_BYTES."""
    size = chunk.uncompressed_size
    try:
        if chunk.compression == "zstd":
            reader = zstandard.ZstdDecompressor().stream_reader(chunk.data, read_across_frames=True)
            data = reader.read(size + 1)
        elif chunk.compression == "lz4":
            data = lz4.frame.LZ4FrameDecompressor().decompress(chunk.data, max_length=size + 1)
        elif chunk.compression == "":
            data = chunk.data
        else:
            raise RecordingError(f"{where}: unknown compression {chunk.compression!r}")
    except (zstandard.ZstdError, RuntimeError) as err:
        raise RecordingError(f"{where}: its {chunk.compression} data is corrupt ({err})") from None
    if len(data) != size:
        more = "more" if len(data) > size else f"{len(data)} B"
        raise RecordingError(f"{where}: declares {size} B decompressed but holds {more}")
    return data


_RECORD = struct.Struct("<BQ")  # opcode, length
_MESSAGE = struct.Struct("<HIQQ")  # channel id, sequence, log time, publish time


class _Reader(StreamReader):
    """mcap's StreamReader, skipping the message-index records it would parse a field at a
    time: one per chunk, an entry per message, a fifth of a report's time, read by no one here."""

    record_offset = 0  # where the record read last starts: a chunk is re-read from there

    def _read_record(self, opcode: int, length: int) -> Any:
        self.record_offset = self._stream.count - 9  # its opcode and length are read
        if opcode == Opcode.MESSAGE_INDEX:
            self._stream.read(length)
            return None
        return super()._read_record(opcode, length)


class _Oversize(Exception):  # not a ValueError: never taken for a file cut short
    pass


class _Bounded:
    """A file the `mcap` records read from, refusing a field that declares more bytes than a
    record may hold (a chunk's data length is not checked against its record's length) or a
    negative count (a message record shorter than its header), before a read allocates."""

    def __init__(self, raw: BinaryIO | BytesIO) -> None:
        self._raw = raw

    def read(self, size: int) -> bytes:
        if not 0 <= size <= MAX_RECORD_BYTES:
            raise _Oversize(f"a record declares a field of {size} B (bound {MAX_RECORD_BYTES} B)")
        return self._raw.read(size)

    def tell(self) -> int:
        return self._raw.tell()


def _exactly(stream: BinaryIO, size: int, path: Path) -> bytes:
    data = stream.read(size)
    if len(data) != size:
        raise RecordingError(f"{path}: the file changed while it was replayed (it is shorter)")
    return data


# JSON text without its strings, reduced to brackets: its nesting, counted at C speed. A string
# left open runs to the end (\Z), so no match fails and the scan stays linear.
_STRING = re.compile(rb'"(?:[^"\\]|\\.|\\\Z)*(?:"|\Z)', re.DOTALL)
_INNERMOST = re.compile(rb"\[\]|\{\}")
_NOT_BRACKET = bytes(b for b in range(256) if b not in b"[]{}")


def decode_json(data: bytes) -> Any:
    """json.loads, refusing nesting deeper than MAX_JSON_DEPTH before the parser recurses into
    it (200,000 levels end in a RecursionError, or later in whoever walks the value), and text
    over MAX_JSON_BYTES."""
    if len(data) > MAX_JSON_BYTES:
        raise RecordingError(f"JSON message of {len(data)} B, over {MAX_JSON_BYTES} B")
    if data.count(b"[") + data.count(b"{") > MAX_JSON_DEPTH:
        brackets = _STRING.sub(b"", data).translate(None, _NOT_BRACKET)
        for _ in range(MAX_JSON_DEPTH):  # each pass takes off one level
            brackets, removed = _INNERMOST.subn(b"", brackets)
            if not brackets:
                break
            if not removed:
                raise RecordingError("not valid JSON (its brackets do not pair)")
        else:
            raise RecordingError(f"JSON nested deeper than {MAX_JSON_DEPTH}")
    try:
        return json.loads(data)
    except (ValueError, RecursionError) as err:
        raise RecordingError(f"not valid JSON ({type(err).__name__})") from None
