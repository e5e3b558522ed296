"""Hostile recordings: a file no writer of ours made is refused with a named error (ptwl report
and ptwl replay-serve: exit 2, one line on stderr naming the file and the problem), before it
can take the memory or the stack. Each file here is one the old reader (every message decoded
into a list by mcap's StreamReader) crashed on or blew up with."""

import json
import subprocess
import sys
from pathlib import Path

import pytest
import zstandard
from mcap.data_stream import RecordBuilder
from mcap.records import Channel, Chunk, DataEnd, Footer, Header, Message, Schema
from mcap.stream_reader import MAGIC_SIZE
from mcap.writer import Writer

from ptwl.recording import topics
from ptwl.recording.reader import (
    MAX_CHUNK_BYTES,
    MAX_JSON_BYTES,
    MAX_JSON_DEPTH,
    RecordingError,
    Scan,
    decode_json,
    read,
)
from ptwl.recording.replay.timeline import Timeline
from ptwl.recording.report import MAX_TRIAL_STEPS, report_json
from tests.command_line import run_ptwl

MAGIC = b"\x89MCAP0\r\n"
assert len(MAGIC) == MAGIC_SIZE
BOMB_B = 1_500_000_000  # what the outside report's 45 KB file expanded to
RSS_BOUND_MB = 400  # a reader that decompressed the bomb held >= 1,430 MB (3,000 MB measured)


def _records(*records: object) -> bytes:
    out = RecordBuilder()
    for record in records:
        record.write(out)  # type: ignore[attr-defined]
    return out.end()


def _file(path: Path, *records: object, finished: bool = True) -> Path:
    """magic, a header, the records, and (finished) a data end and footer."""
    tail = [DataEnd(0), Footer(0, 0, 0)] if finished else []
    path.write_bytes(
        MAGIC
        + _records(Header(profile="ptwl", library="test"), *records, *tail)
        + (MAGIC if finished else b"")
    )
    return path


def _json_channel(topic: topics.Topic, channel_id: int = 1) -> list[object]:
    schema = Schema(id=1, name=topic.schema, encoding="jsonschema", data=b"{}")
    return [
        schema,
        Channel(id=channel_id, topic=topic.name, message_encoding="json", schema_id=1, metadata={}),
    ]


def _message(data: bytes, channel_id: int = 1, ns: int = 1) -> Message:
    return Message(channel_id=channel_id, log_time=ns, data=data, publish_time=ns, sequence=0)


def _chunk(inner: bytes, declared: int | None = None, data: bytes | None = None) -> Chunk:
    return Chunk(
        compression="zstd",
        data=zstandard.ZstdCompressor().compress(inner) if data is None else data,
        message_start_time=0,
        message_end_time=0,
        uncompressed_crc=0,
        uncompressed_size=len(inner) if declared is None else declared,
    )


def _bomb() -> bytes:
    """zstd of BOMB_B zero bytes: ~46 KB, streamed so the test never holds the zeros."""
    compressor = zstandard.ZstdCompressor().compressobj()
    block = bytes(16 * 2**20)
    parts = [compressor.compress(block) for _ in range(BOMB_B // len(block))]
    parts.append(compressor.compress(bytes(BOMB_B % len(block))))
    parts.append(compressor.flush())
    return b"".join(parts)


def _run(*args: str, timeout_s: float = 120.0) -> tuple[int, str, float]:
    """`ptwl ARGS` in a fresh interpreter (a forked one would start with the zygote's memory): its
    exit code, stderr, and peak RSS [MB]."""
    code = (  # VmHWM, not ru_maxrss: the latter keeps pytest's RSS (the forking parent) across exec
        "import sys\nfrom ptwl.cli import main\nrc = main(sys.argv[1:])\n"
        "peak = next(line.split()[1] for line in open('/proc/self/status') if line.startswith('VmHWM'))\n"
        "print('peak_kb', peak, file=sys.stderr)\nsys.exit(rc)"
    )
    command = [sys.executable, "-c", code, *args]
    done = subprocess.run(command, capture_output=True, text=True, timeout=timeout_s)
    lines = done.stderr.strip().splitlines()
    peak = [line for line in lines if line.startswith("peak_kb ")]
    said = "\n".join(line for line in lines if not line.startswith("peak_kb "))
    return done.returncode, said, int(peak[-1].split()[1]) / 1024 if peak else float("nan")


def _said(*args: str, timeout_s: float = 120.0) -> tuple[int, str]:
    """`ptwl ARGS` run to its end: its exit code and what it said on stderr."""
    done = run_ptwl(*args, timeout=timeout_s)
    return done.returncode, done.stderr.strip()


def _refused(path: Path, *expected: str) -> None:
    """Both readers name the problem: report exits 2 with one line, replay-serve too."""
    for command in ("report", "replay-serve"):
        code, said = _said(command, str(path))
        assert code == 2, (command, said)
        assert len(said.splitlines()) == 1 and "Traceback" not in said, said
        assert said.startswith(f"ptwl: {path}:"), said
        for text in expected:
            assert text in said, (command, said)


@pytest.fixture(scope="module")
def bomb() -> bytes:
    return _bomb()


def test_a_zstd_bomb_is_refused_by_its_declared_size_in_bounded_memory(tmp_path: Path, bomb: bytes) -> None:
    path = _file(tmp_path / "bomb.mcap", *_json_channel(topics.STEPS), _chunk(b"", BOMB_B, bomb))
    assert path.stat().st_size < 60_000  # the outside report's 45 KB file
    with pytest.raises(RecordingError, match=f"declares {BOMB_B} B decompressed, over {MAX_CHUNK_BYTES} B"):
        report_json(path)
    code, said, peak_mb = _run("report", str(path))
    assert code == 2 and said.startswith(f"ptwl: {path}: chunk at byte "), said
    assert said.endswith(f": declares {BOMB_B} B decompressed, over {MAX_CHUNK_BYTES} B"), said
    assert peak_mb < RSS_BOUND_MB, peak_mb


def test_a_chunk_that_lies_about_its_size_costs_at_most_what_it_declared(tmp_path: Path, bomb: bytes) -> None:
    """It declares 1 MiB and holds 1.5 GB: decompression stops one byte past the declared size."""
    path = _file(tmp_path / "liar.mcap", *_json_channel(topics.STEPS), _chunk(b"", 2**20, bomb))
    with pytest.raises(RecordingError, match="declares 1048576 B decompressed but holds more"):
        report_json(path)
    code, said, peak_mb = _run("report", str(path))
    assert code == 2 and "holds more" in said and peak_mb < RSS_BOUND_MB, (said, peak_mb)
    short = _file(tmp_path / "short.mcap", _chunk(b"\x05" * 100, 60 * 2**20))
    with pytest.raises(RecordingError, match="declares 62914560 B decompressed but holds 100 B"):
        read(short)


def test_a_file_decompressing_past_the_total_bound_is_refused(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from ptwl.recording import reader

    inner = _records(*_json_channel(topics.STEPS), *[_message(b"{}", ns=i) for i in range(100)])
    path = _file(tmp_path / "many.mcap", *[_chunk(inner) for _ in range(10)])
    assert read(path).count == 1000
    monkeypatch.setattr(reader, "MAX_TOTAL_BYTES", 5 * len(inner))  # five chunks' worth
    with pytest.raises(RecordingError, match=r"chunk at byte \d+: the file decompresses to over"):
        read(path)


def test_a_message_on_a_channel_never_defined_is_named(tmp_path: Path) -> None:
    """The old reader: KeyError: 1, a traceback."""
    inner = _records(_message(b"{}", channel_id=1))
    path = _file(tmp_path / "orphan.mcap", _chunk(inner))
    _refused(path, "message 1 is on channel 1, which no channel record before it defines")


@pytest.mark.parametrize("topic", [topics.GEOMETRY, topics.TELEMETRY])
def test_json_nested_200000_deep_is_named_not_a_recursion_error(tmp_path: Path, topic: topics.Topic) -> None:
    """The old reader: RecursionError, a traceback. /ptwl/geometry is what report decodes,
    /ptwl/telemetry what replay serves (report counts it and never decodes it)."""
    deep = b"[" * 200_000 + b"]" * 200_000
    fine = json.dumps({"scene": "surface", "sim_time": 0.0, "bodies": {}}).encode()
    messages = [_message(fine, ns=1), _message(deep, ns=2)]
    path = _file(tmp_path / "deep.mcap", _chunk(_records(*_json_channel(topic), *messages)))
    expected = f"message 2 on {topic.name}: JSON nested deeper than {MAX_JSON_DEPTH}"
    if topic is topics.GEOMETRY:
        _refused(path, expected)
    else:
        assert report_json(path) == []  # no trial: nothing decoded, nothing wrong
        code, said = _said("replay-serve", str(path))
        assert code == 2 and said == f"ptwl: {path}: {expected}", said
        # `ptwl replay` says what its stand-in said as it exited, not after the 120 s it would
        # give a file to be indexed (the launcher waited for a URL that never came).
        code, said = _said("replay", str(path), "--port", "0", timeout_s=60.0)
        assert code == 2 and said == f"ptwl: {path}: {expected}", said


def test_json_depth_is_bounded_exactly_and_brackets_in_strings_do_not_count() -> None:
    def nested(depth: int) -> bytes:
        return b'{"a":' * (depth - 1) + b"[1]" + b"}" * (depth - 1)

    assert decode_json(nested(MAX_JSON_DEPTH)) is not None
    with pytest.raises(RecordingError, match=f"nested deeper than {MAX_JSON_DEPTH}"):
        decode_json(nested(MAX_JSON_DEPTH + 1))
    quoted = json.dumps({"detail": "[{" * 500 + '"\\"', "steps": [[1]] * 200}).encode()
    assert decode_json(quoted)["detail"].startswith("[{[{")
    with pytest.raises(RecordingError, match="brackets do not pair"):
        decode_json(b"[" * 100 + b"]")
    with pytest.raises(RecordingError, match="not valid JSON"):
        decode_json(b'{"a": 1')
    unterminated = b'"' + b'\\"' * 50_000 + b"[" * 70  # a string left open: scanned once, not 50,000 times
    with pytest.raises(RecordingError, match="not valid JSON"):
        decode_json(unterminated)


def test_malformed_records_inside_a_chunk_are_named(tmp_path: Path) -> None:
    short_message = bytes([5]) + (10).to_bytes(8, "little") + bytes(10)  # a message under its header
    path = _file(tmp_path / "short_message.mcap", _chunk(short_message))
    with pytest.raises(RecordingError, match="a message record of 10 B, under its header"):
        read(path)
    overrun = bytes([5]) + (10_000).to_bytes(8, "little") + bytes(30)
    path = _file(tmp_path / "overrun.mcap", _chunk(overrun))
    with pytest.raises(RecordingError, match="a record runs past the chunk's end"):
        read(path)
    path = _file(tmp_path / "garbage.mcap", _chunk(b"", 100, b"\x28\xb5\x2f\xfd\x00\x58" + b"\xff" * 60))
    with pytest.raises(RecordingError, match="zstd data is corrupt"):
        read(path)


def test_a_field_declaring_more_than_a_record_may_hold_is_refused_before_it_is_read(tmp_path: Path) -> None:
    """A chunk record of ordinary length whose data-length field says 1 TB: the old reader
    asked the file for 1 TB (a MemoryError, or as much of a large file as there is)."""
    chunk = _records(_chunk(b"x"))
    length_at = 9 + 8 + 8 + 8 + 4 + 4 + len("zstd")
    lying = chunk[:length_at] + (10**12).to_bytes(8, "little") + chunk[length_at + 8 :]
    path = tmp_path / "field.mcap"
    path.write_bytes(MAGIC + _records(Header(profile="ptwl", library="test")) + lying + bytes(100))
    _refused(path, "a record declares a field of 1000000000000 B")


def test_a_chunk_the_writer_never_finished_is_a_cut_short_file_not_an_error(tmp_path: Path) -> None:
    """The Foxglove writer declares a chunk 2^64 - 1 bytes long until it finishes it: a kill -9
    leaves that at the file's end. It is past the end of the file, so the file was cut short."""
    whole = _chunk(_records(*_json_channel(topics.STEPS), _message(b"{}")))
    unfinished = bytes([6]) + (2**64 - 1).to_bytes(8, "little") + bytes(50)
    path = _file(tmp_path / "killed.mcap", whole, finished=False)
    path.write_bytes(path.read_bytes() + unfinished)
    recording = read(path)
    assert recording.count == 1 and not recording.complete
    assert "runs past the end of the file" in recording.problem


def test_a_protobuf_channel_without_its_schema_is_named(tmp_path: Path) -> None:
    channel = Channel(id=1, topic="/tf", message_encoding="protobuf", schema_id=9, metadata={})
    path = _file(tmp_path / "noschema.mcap", _chunk(_records(channel, _message(b"\x0a\x00"))))
    with pytest.raises(
        RecordingError, match=r"message 1 on /tf: no decoder for encoding 'protobuf' \(schema 9"
    ):
        read(path)
    assert Scan(path, [topics.STEPS.name]).count == 0  # not asked for: never decoded, never wrong
    assert list(Scan(path, [topics.STEPS.name])) == []


def test_report_and_replay_name_messages_that_are_not_what_the_routes_read(tmp_path: Path) -> None:
    path = tmp_path / "shapes.mcap"
    with path.open("wb") as f:
        writer = Writer(f)
        writer.start("ptwl", "test")
        ids = {}
        for topic in (topics.GEOMETRY, topics.TELEMETRY, topics.STEPS):
            schema = writer.register_schema(topic.schema, "jsonschema", b"{}")
            ids[topic.name] = writer.register_channel(topic.name, "json", schema)
        writer.add_message(ids["/ptwl/geometry"], 1, b'{"scene": "surface"}', 1)
        writer.add_message(ids["/ptwl/telemetry"], 2, b'{"sim_time": "soon"}', 2)
        writer.add_message(ids["/steps"], 3, b'{"behavior": "ptwl"}', 3)
        writer.finish()
    with pytest.raises(RecordingError, match=r"/steps message of the surface trial .* is no ptwl\.Step"):
        report_json(path)
    with pytest.raises(
        RecordingError, match=r"message 2 on /ptwl/telemetry: not a ptwl.Telemetry \(needs sim_time\)"
    ):
        Timeline(path)


def test_a_json_message_over_its_bound_is_refused_before_it_is_decoded(tmp_path: Path) -> None:
    """Flat, but 5 MiB of `[],` decodes to ~1.7 M lists (~110 MB): over MAX_JSON_BYTES it is named."""
    big = b"[" + b"[]," * (5 * 2**20 // 3) + b"[]]"
    path = _file(tmp_path / "big.mcap", _chunk(_records(*_json_channel(topics.GEOMETRY), _message(big))))
    _refused(
        path, f"message 1 on {topics.GEOMETRY.name}: JSON message of {len(big)} B, over {MAX_JSON_BYTES} B"
    )


def test_a_trial_with_more_steps_than_its_bound_is_refused(tmp_path: Path) -> None:
    geometry = json.dumps({"scene": "surface", "bodies": {}}).encode()
    step = json.dumps({"behavior": "rwe", "exit": "completed"}).encode()
    steps = [_message(step, channel_id=2, ns=2 + i) for i in range(MAX_TRIAL_STEPS + 1)]
    inner = _records(
        *_json_channel(topics.GEOMETRY), *_json_channel(topics.STEPS, 2), _message(geometry), *steps
    )
    path = _file(tmp_path / "steps.mcap", _chunk(inner))
    code, said = _said("report", str(path))  # a report holds a trial's steps; replay never does
    assert (
        code == 2 and said == f"ptwl: {path}: the surface trial at 1 ns has over {MAX_TRIAL_STEPS} steps"
    ), said
