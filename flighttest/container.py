"""The MCAP container walk under `read_record`: every record, every CRC, where damage is.

Record fields are decoded by the `mcap` package's own record readers
(`mcap.records.*.read`); opcodes are `mcap.opcode.Opcode`.  The framing loop
around them is this module's because `mcap.stream_reader.StreamReader` and
`mcap.reader.make_reader` do not do what the contract needs of it:

- a record's fields are not bounded by its declared length or by the end of
  the file (a short read returns fewer bytes in silence), so a damaged length
  would be half-read instead of refused;
- a recording cut inside a record is not told apart from damage (the short
  read hands a partial record on), where `salvage` must stop at the last
  complete record;
- the summary CRC, the closing magic, "Header first" and the Statistics
  counts are not checked, and nothing says at which byte a file is damaged;
- zstd chunks are inflated into a buffer sized by the (possibly damaged)
  uncompressed-size field.

Messages inside chunks, nearly all of a file, are unpacked inline with one
`struct` call each (the layout of `mcap.records.Message`): one
`Message.read` per message would multiply the reading time of a 1 kHz log.
"""
from __future__ import annotations

import io
import struct
import zlib
from dataclasses import dataclass, field

from mcap import records as R
from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode

MAGIC = b"\x89MCAP0\r\n"
# A chunk that claims to inflate beyond this is damage, not data; refusing it
# keeps a flipped size field from exhausting memory.
_MAX_CHUNK_BYTES = 1 << 30
_MESSAGE_HEAD = struct.Struct("<HIQQ")  # channel id, sequence, log_time, publish_time


class ContainerDamage(Exception):
    """Container-level damage; str() says what and at which byte."""


def _name(opcode: int) -> str:
    try:
        return Opcode(opcode).name.title().replace("_", "")  # DATA_END -> DataEnd
    except ValueError:
        return f"opcode {opcode:#04x}"


class _Bounded(ReadDataStream):
    """The bytes of one record: a read past its end is damage, never a short read."""

    def __init__(self, data: bytes, offset: int):
        super().__init__(io.BytesIO(data))
        self._size, self._offset = len(data), offset

    def read(self, length: int) -> bytes:
        if length < 0 or self.count + length > self._size:
            raise ContainerDamage(f"field runs past the end of its record at byte "
                                  f"{self._offset + self.count}")
        return super().read(length)


def _decode(reader, data: bytes, offset: int, *args):
    """Run an `mcap.records` reader over one record's bytes."""
    try:
        return reader(_Bounded(data, offset), *args)
    except UnicodeDecodeError:
        raise ContainerDamage(f"string is not UTF-8 in the record at byte {offset}") from None


@dataclass
class RawRecords:
    """What the walk found, before any contract check."""

    schemas: dict[int, tuple[str, str, bytes]] = field(default_factory=dict)
    channels: dict[int, tuple[int, str, str]] = field(default_factory=dict)
    metadata: list[tuple[str, dict[str, str]]] = field(default_factory=list)
    # channel id -> (log_time, publish_time, data) in file order
    messages: dict[int, list[tuple[int, int, bytes]]] = field(default_factory=dict)
    stats: R.Statistics | None = None
    had_summary: bool = False
    truncated: bool = False

    def add_schema(self, s: R.Schema) -> None:
        if s.id == 0:
            raise ContainerDamage("schema id 0 is reserved")
        entry = (s.name, s.encoding, bytes(s.data))
        if self.schemas.setdefault(s.id, entry) != entry:
            raise ContainerDamage(f"schema id {s.id} is declared twice with different contents")

    def add_channel(self, c: R.Channel) -> None:
        entry = (c.schema_id, c.topic, c.message_encoding)
        if self.channels.setdefault(c.id, entry) != entry:
            raise ContainerDamage(f"channel id {c.id} is declared twice with different contents")

    def add_message(self, cid: int, log_time: int, publish_time: int, data: bytes) -> None:
        msgs = self.messages.get(cid)
        if msgs is None:
            if cid not in self.channels:
                raise ContainerDamage(f"message on channel id {cid}, which no Channel record "
                                      f"declares before it")
            msgs = self.messages[cid] = []
        msgs.append((log_time, publish_time, data))


def _decompress(compression: str, data: bytes, size: int) -> bytes:
    if size > _MAX_CHUNK_BYTES:
        raise ContainerDamage(f"chunk claims {size} uncompressed bytes")
    if compression == "":
        out = data
    elif compression == "zstd":
        import zstandard
        try:
            # Streaming, so the output grows with the data actually present
            # rather than being allocated from a size field that may be damaged.
            out = zstandard.ZstdDecompressor().decompressobj().decompress(data)
        except zstandard.ZstdError as exc:
            raise ContainerDamage(f"zstd data does not decompress ({exc})") from None
    elif compression == "lz4":
        import lz4.frame
        try:
            out = lz4.frame.decompress(data)
        except RuntimeError as exc:
            raise ContainerDamage(f"lz4 data does not decompress ({exc})") from None
    else:
        raise ContainerDamage(f"unsupported chunk compression {compression!r} "
                              f"(contract: zstd, lz4 or none)")
    if len(out) != size:
        raise ContainerDamage(f"chunk inflates to {len(out)} bytes, its header says {size}")
    return out


def _walk_chunk(raw: RawRecords, chunk: R.Chunk, offset: int) -> None:
    data = _decompress(chunk.compression, chunk.data, chunk.uncompressed_size)
    crc = chunk.uncompressed_crc
    if crc != 0 and zlib.crc32(data) != crc:
        raise ContainerDamage(f"CRC mismatch in Chunk at byte {offset}: "
                              f"stored {crc:#010x}, computed {zlib.crc32(data):#010x}")
    pos, end = 0, len(data)
    while pos < end:
        if end - pos < 9:
            raise ContainerDamage(f"record header cut short inside Chunk at byte {offset}")
        opcode, length = struct.unpack_from("<BQ", data, pos)
        if length > end - pos - 9:
            raise ContainerDamage(f"record inside Chunk at byte {offset} runs past the chunk end")
        body = pos + 9
        if opcode == Opcode.MESSAGE:
            if length < _MESSAGE_HEAD.size:
                raise ContainerDamage(f"Message inside Chunk at byte {offset} is shorter "
                                      f"than its header")
            cid, _, log_time, publish_time = _MESSAGE_HEAD.unpack_from(data, body)
            raw.add_message(cid, log_time, publish_time, data[body + _MESSAGE_HEAD.size:body + length])
        elif opcode == Opcode.SCHEMA:
            raw.add_schema(_decode(R.Schema.read, data[body:body + length], offset))
        elif opcode == Opcode.CHANNEL:
            raw.add_channel(_decode(R.Channel.read, data[body:body + length], offset))
        elif opcode == 0:
            raise ContainerDamage(f"invalid opcode 0x00 inside Chunk at byte {offset}")
        pos = body + length


def _footer(buf: bytes, pos: int, length: int, footer: R.Footer, raw: RawRecords,
            data_end_seen: bool) -> None:
    if buf[pos + 9 + length:] != MAGIC:
        raise ContainerDamage(f"bytes after the Footer at byte {pos} are not the closing magic")
    if footer.summary_start:
        if not pos >= footer.summary_start > len(MAGIC):
            raise ContainerDamage(f"Footer points its summary at byte {footer.summary_start}, "
                                  f"outside the file's summary area")
        computed = zlib.crc32(buf[footer.summary_start:pos + 9 + 16])
        if footer.summary_crc != 0 and computed != footer.summary_crc:
            raise ContainerDamage(f"summary-section CRC mismatch: stored {footer.summary_crc:#010x}, "
                                  f"computed {computed:#010x}")
        raw.had_summary = True
    if not data_end_seen:
        raise ContainerDamage("Footer reached without a DataEnd record")


def walk(buf: bytes, salvage: bool) -> RawRecords:
    """Walk every record of an MCAP byte string; raise ContainerDamage on any fault.

    A file that ends cleanly between records (a recording stopped without
    its summary) is read and marked `truncated`; one cut inside a record is
    refused unless `salvage`, which keeps the complete records before the cut.
    """
    n = len(buf)
    if n < len(MAGIC) or buf[:len(MAGIC)] != MAGIC:
        raise ContainerDamage("not an MCAP file (bad magic at byte 0)")
    raw = RawRecords()
    pos = len(MAGIC)
    first = True
    data_end_seen = False
    while True:
        if pos == n:
            raw.truncated = True
            if first:
                raise ContainerDamage("file holds only the magic bytes")
            return raw
        if n - pos < 9:
            if salvage or data_end_seen:
                raw.truncated = True
                return raw
            raise ContainerDamage(f"file truncated in a record header at byte {pos}")
        opcode, length = struct.unpack_from("<BQ", buf, pos)
        name = _name(opcode)
        if length > n - pos - 9:
            if salvage or data_end_seen:
                raw.truncated = True
                return raw
            raise ContainerDamage(f"{name} record at byte {pos} claims {length} bytes, "
                                  f"only {n - pos - 9} remain: file truncated or damaged "
                                  f"(salvage reads the complete records before it)")
        if first and opcode != Opcode.HEADER:
            raise ContainerDamage(f"first record is {name}, not Header")
        first = False
        if opcode == 0:
            raise ContainerDamage(f"invalid opcode 0x00 at byte {pos}")
        body = buf[pos + 9:pos + 9 + length]
        if opcode == Opcode.CHUNK:
            _walk_chunk(raw, _decode(R.Chunk.read, body, pos), pos)
        elif opcode == Opcode.SCHEMA:
            # Repeats in the summary must agree with the data section's.
            raw.add_schema(_decode(R.Schema.read, body, pos))
        elif opcode == Opcode.CHANNEL:
            raw.add_channel(_decode(R.Channel.read, body, pos))
        elif opcode == Opcode.MESSAGE and not data_end_seen:
            m = _decode(R.Message.read, body, pos, length)  # an unchunked file
            raw.add_message(m.channel_id, m.log_time, m.publish_time, bytes(m.data))
        elif opcode == Opcode.METADATA and not data_end_seen:
            md = _decode(R.Metadata.read, body, pos)
            # `Metadata.read` keeps the last of two equal keys: a map whose
            # pairs take more bytes than the distinct keys do repeats one.
            pairs = sum(8 + len(k.encode()) + len(v.encode()) for k, v in md.metadata.items())
            if 8 + len(md.name.encode()) + pairs != length:
                raise ContainerDamage(f"Metadata record at byte {pos} repeats a key or holds "
                                      f"bytes that are not key-value pairs")
            raw.metadata.append((md.name, dict(md.metadata)))
        elif opcode == Opcode.STATISTICS:
            raw.stats = _decode(R.Statistics.read, body, pos)
        elif opcode == Opcode.DATA_END:
            crc = _decode(R.DataEnd.read, body, pos).data_section_crc
            if crc != 0 and zlib.crc32(buf[:pos]) != crc:
                raise ContainerDamage(f"data-section CRC mismatch (DataEnd at byte {pos}): "
                                      f"stored {crc:#010x}, computed {zlib.crc32(buf[:pos]):#010x}")
            data_end_seen = True
        elif opcode == Opcode.FOOTER:
            _footer(buf, pos, length, _decode(R.Footer.read, body, pos), raw, data_end_seen)
            return raw
        pos += 9 + length
