"""The one path from a file name to bytes, text, YAML data or an image's bytes, for every input file.

Scenario, task, settings, team, plan, map and experiment files all come through here, so a bad
file is refused the same way everywhere, before it can block, exhaust memory or crash a parser:

* the path: no NUL byte, at most :data:`MAX_PATH_BYTES`, each component at most
  :data:`MAX_NAME_BYTES` (longer ones cannot exist on Linux; ``stat`` would raise);
* the file: a regular file (a FIFO would block the reader, a device such as ``/dev/zero`` never
  ends, a directory is no file), checked with ``stat`` before it is opened, and opened
  non-blocking and checked again, so a file swapped for a FIFO in between cannot block either;
* its size: at most :data:`MAX_TEXT_BYTES` for text, :data:`MAX_IMAGE_BYTES` for images;
* text: UTF-8, the offset of the first bad byte named;
* YAML: nesting at most :data:`MAX_YAML_DEPTH` and at most :data:`MAX_YAML_NODES` nodes counted
  with every alias expanded (a "billion laughs" file is refused before it is built; a recursive
  alias too), errors give line and column but never the file's text;
* images: PNG, JPEG, BMP or PNM, their size read from the header and bounded by
  :data:`MAX_IMAGE_PIXELS` before any decoder runs, a PNG without its end chunk or a JPEG
  without its end marker refused as truncated. Decoding is the image modules' job (OpenCV).

Every error is the caller's type (a :class:`ConfigurationError`) and reads
``<what> '<path>': <problem>``; the caller puts the field or parameter in front. Values and paths
are echoed at most :data:`ECHO_LIMIT` characters long.
"""
from __future__ import annotations

import os
import stat
import struct
from pathlib import Path
from typing import Any

import yaml

from .errors import ConfigurationError
from .settings import ECHO_LIMIT, echo

ErrorType = type[ValueError]

#: Longest file name component Linux file systems hold (NAME_MAX).
MAX_NAME_BYTES = 255
#: Longest path the kernel takes (PATH_MAX, 4096 with the terminating NUL).
MAX_PATH_BYTES = 4095
#: Largest text (YAML) file: the workspace's files are at most tens of KiB; parsing 1.3 MB of YAML
#: took 3.7 s (libyaml, load 4.5), so a mistaken file (a log, a bag) is refused at once instead.
MAX_TEXT_BYTES = 1 << 20
#: Most YAML nodes, every alias expanded: 100,000 nodes build in about a second; a 100-robot
#: scenario has about 2,000. Aliases may only make a file bigger within this bound.
MAX_YAML_NODES = 100_000
#: Deepest YAML nesting: libyaml's composer recurses, 100,000 nested lists crash the process.
MAX_YAML_DEPTH = 64
#: Largest image file (a 4096 x 4096 RGBA PNG is at most about 64 MiB).
MAX_IMAGE_BYTES = 64 << 20
#: Most pixels of an image: 4096 x 4096 = 16.8 M. Maps are read as float arrays (8 bytes a pixel,
#: times the colour channels): 10,000 x 10,000 ran out of memory; 16.8 M needs about 400 MB at most.
MAX_IMAGE_PIXELS = 4096 * 4096

_FILE_KINDS = ((stat.S_ISDIR, 'a directory'), (stat.S_ISFIFO, 'a FIFO'), (stat.S_ISCHR, 'a character device'),
               (stat.S_ISBLK, 'a block device'), (stat.S_ISSOCK, 'a socket'))


def shown_path(path: Any) -> str:
    """A path as error messages show it: at most ECHO_LIMIT characters (its start and its end)."""
    text = os.fspath(path) if isinstance(path, (str, os.PathLike)) else repr(path)
    if isinstance(text, bytes):
        text = os.fsdecode(text)
    if len(text) <= ECHO_LIMIT:
        return text
    half = (ECHO_LIMIT - 3) // 2
    return f'{text[:half]}...{text[-half:]}'


def _where(path: Any, what: str) -> str:
    return f"{what} '{shown_path(path)}'"


def check_path(path: Any, what: str = 'file', error: ErrorType = ConfigurationError) -> Path:
    """``path`` as a Path, or ``error`` when no file could have that name (before any system call)."""
    if not isinstance(path, (str, os.PathLike)):
        raise error(f'{what}: must be a path (got {echo(path)})')
    text = os.fspath(path)
    if isinstance(text, bytes):
        text = os.fsdecode(text)
    if not text:
        raise error(f'{what}: empty path')
    where = _where(text, what)
    if '\0' in text:
        raise error(f'{where}: contains a NUL character')
    encoded = os.fsencode(text)
    if len(encoded) > MAX_PATH_BYTES:
        raise error(f'{where}: path is {len(encoded)} bytes long (at most {MAX_PATH_BYTES}, the system\'s PATH_MAX)')
    longest = max(len(part) for part in encoded.split(b'/'))
    if longest > MAX_NAME_BYTES:
        raise error(f'{where}: a path component is {longest} bytes long (at most {MAX_NAME_BYTES}, '
                    "the file system's NAME_MAX)")
    return Path(text)


def _stat_problem(error: OSError) -> str:
    if isinstance(error, FileNotFoundError):
        return 'does not exist'
    if isinstance(error, NotADirectoryError):
        return 'does not exist (a component of the path is not a directory)'
    if isinstance(error, PermissionError):
        return 'permission denied'
    return f'cannot read ({error.strerror or type(error).__name__})'


def _kind_problem(mode: int) -> str | None:
    if stat.S_ISREG(mode):
        return None
    kind = next((name for test, name in _FILE_KINDS if test(mode)), 'a special file')
    return f'not a regular file ({kind})'


def read_file_bytes(path: Any, what: str = 'file', error: ErrorType = ConfigurationError,
                    max_bytes: int = MAX_TEXT_BYTES) -> bytes:
    """The content of the regular file ``path``, at most ``max_bytes`` long (module docstring)."""
    path = check_path(path, what, error)
    where = _where(path, what)
    try:
        info = os.stat(path)
    except OSError as err:
        raise error(f'{where}: {_stat_problem(err)}') from None
    problem = _kind_problem(info.st_mode)
    if problem is None and info.st_size > max_bytes:
        problem = f'is {info.st_size} bytes (at most {max_bytes})'
    if problem:
        raise error(f'{where}: {problem}')
    try:
        descriptor = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_CLOEXEC)
    except OSError as err:
        raise error(f'{where}: {_stat_problem(err)}') from None
    try:
        problem = _kind_problem(os.fstat(descriptor).st_mode)   # replaced since the stat above
        if problem:
            raise error(f'{where}: {problem}')
        chunks, size = [], 0
        while size <= max_bytes:
            chunk = os.read(descriptor, max_bytes + 1 - size)
            if not chunk:
                break
            chunks.append(chunk)
            size += len(chunk)
    except OSError as err:
        raise error(f'{where}: {_stat_problem(err)}') from None
    finally:
        os.close(descriptor)
    if size > max_bytes:
        raise error(f'{where}: is more than {max_bytes} bytes (it grew while read)')
    return b''.join(chunks)


def read_text_file(path: Any, what: str = 'file', error: ErrorType = ConfigurationError,
                   max_bytes: int = MAX_TEXT_BYTES) -> str:
    """The UTF-8 text of the regular file ``path`` (module docstring)."""
    data = read_file_bytes(path, what, error, max_bytes)
    try:
        return data.decode('utf-8')
    except UnicodeDecodeError as err:
        raise error(f'{_where(path, what)}: not UTF-8 text (byte 0x{data[err.start]:02x} at offset {err.start})') \
            from None


# --- YAML --------------------------------------------------------------------------------------

_Loader = getattr(yaml, 'CSafeLoader', yaml.SafeLoader)
_COLLECTION_START = (yaml.SequenceStartEvent, yaml.MappingStartEvent)
_COLLECTION_END = (yaml.SequenceEndEvent, yaml.MappingEndEvent)


def _capped(text: str) -> str:
    return text if len(text) <= ECHO_LIMIT else text[:ECHO_LIMIT - 3] + '...'


def _yaml_error_text(err: yaml.YAMLError) -> str:
    """What a YAML error says, with its line and column, without the file's text (which it quotes)."""
    mark = getattr(err, 'problem_mark', None)
    problem = getattr(err, 'problem', None) or getattr(err, 'context', None) or type(err).__name__
    where = f' at line {mark.line + 1}, column {mark.column + 1}' if mark is not None else ''
    return f'invalid YAML{where}: {_capped(str(problem))}'


def _check_yaml_shape(text: str) -> str | None:
    """Why ``text`` is too deep or too big once its aliases are expanded (None when it is not).

    One pass over the parser's events, no recursion: ``total`` counts the nodes so far, every
    alias expanded; a collection's anchor remembers how many nodes the collection added; an alias
    to an anchor still open is recursive. Undefined aliases are left to the loader's error.
    """
    total = 0
    starts: list[tuple[int, str | None]] = []    # (total before it, anchor) of each open collection
    open_anchors: set[str] = set()
    anchored: dict[str, int] = {}
    for event in yaml.parse(text, Loader=_Loader):
        if isinstance(event, yaml.AliasEvent):
            if event.anchor in open_anchors:
                return f'alias *{_capped(event.anchor)} lies inside its own anchor (a recursive alias)'
            total += anchored.get(event.anchor, 0)
        elif isinstance(event, yaml.ScalarEvent):
            total += 1
            if event.anchor is not None:
                anchored[event.anchor] = 1
        elif isinstance(event, _COLLECTION_START):
            if len(starts) >= MAX_YAML_DEPTH:
                return f'nested more than {MAX_YAML_DEPTH} levels deep'
            starts.append((total, event.anchor))
            if event.anchor is not None:
                open_anchors.add(event.anchor)
            total += 1
        elif isinstance(event, _COLLECTION_END):
            begin, anchor = starts.pop()
            if anchor is not None:
                open_anchors.discard(anchor)
                anchored[anchor] = total - begin
        if total > MAX_YAML_NODES:
            return f'more than {MAX_YAML_NODES} values once its aliases are expanded'
    return None


def load_yaml_text(text: str, error: ErrorType = ConfigurationError) -> Any:
    """``text`` parsed as YAML (safe types only) within the bounds of the module docstring;
    ``error('invalid YAML ...')`` or ``error('YAML ...: <bound>')``; the caller names the source."""
    if not isinstance(text, str):
        raise error(f'must be YAML text (got {type(text).__name__})')
    if len(text.encode('utf-8', 'surrogatepass')) > MAX_TEXT_BYTES:
        raise error(f'YAML text is more than {MAX_TEXT_BYTES} bytes')
    try:
        shape = _check_yaml_shape(text)
        problem = f'YAML {shape}' if shape else None
        data = None if problem else yaml.load(text, Loader=_Loader)
    except yaml.YAMLError as err:
        problem = _yaml_error_text(err)
    except RecursionError:                       # a bound above failed to hold: still no traceback
        problem = f'YAML nested more than {MAX_YAML_DEPTH} levels deep'
    except (ValueError, TypeError, OverflowError) as err:
        # a scalar PyYAML cannot build, e.g. an integer of more than 4300 digits, a date out of range
        problem = f'YAML holds a value that cannot be built ({_capped(str(err))})'
    if problem:
        raise error(problem)
    return data


def read_yaml_file(path: Any, what: str = 'file', error: ErrorType = ConfigurationError) -> Any:
    """The parsed content of a YAML file: ``<what> '<path>': ...`` when it is missing, no regular
    file, too big, not UTF-8, not YAML (or beyond the bounds above) or empty."""
    text = read_text_file(path, what, error)
    try:
        data = load_yaml_text(text, error)
    except error as err:
        raise error(f'{_where(path, what)}: {err}') from None
    if data is None:
        raise error(f'{_where(path, what)}: file is empty')
    return data


def yaml_file_problem(path: str) -> str | None:
    """Why the YAML file a path parameter names cannot be read (None when it can, or for ''): a
    :class:`~.settings.Setting` ``check`` for a file handed to rcl, which would block on a FIFO."""
    try:
        if path:
            read_yaml_file(path)
    except ConfigurationError as error:
        return str(error)
    return None


# --- images --------------------------------------------------------------------------------------

IMAGE_FORMATS = 'a PNG, JPEG, BMP or PNM (PBM, PGM, PPM) image'


def _png_size(data: bytes) -> tuple[int, int, bool]:
    if len(data) < 24 or data[12:16] != b'IHDR':
        return 0, 0, False
    width, height = struct.unpack('>II', data[16:24])
    return width, height, data.rstrip(b'\0')[-8:-4] == b'IEND'


def _jpeg_size(data: bytes) -> tuple[int, int, bool]:
    offset = 2
    while offset + 4 <= len(data):
        if data[offset] != 0xFF:
            return 0, 0, False
        marker = data[offset + 1]
        if marker == 0xFF:                     # fill byte
            offset += 1
            continue
        if marker in (0xD8, 0x01) or 0xD0 <= marker <= 0xD7:
            offset += 2
            continue
        length = struct.unpack('>H', data[offset + 2:offset + 4])[0]
        # SOF0..SOF15 hold the frame size; C4 (DHT), C8 (JPG) and CC (DAC) share the range.
        if 0xC0 <= marker <= 0xCF and marker not in (0xC4, 0xC8, 0xCC) and offset + 9 <= len(data):
            height, width = struct.unpack('>HH', data[offset + 5:offset + 9])
            return width, height, data.rstrip(b'\0')[-2:] == b'\xff\xd9'
        offset += 2 + length
    return 0, 0, False


def _bmp_size(data: bytes) -> tuple[int, int, bool]:
    if len(data) < 26:
        return 0, 0, False
    width, height = struct.unpack('<ii', data[18:26])
    declared = struct.unpack('<I', data[2:6])[0]
    return abs(width), abs(height), len(data) >= declared


def _pnm_size(data: bytes) -> tuple[int, int, bool]:
    tokens: list[bytes] = []
    offset = 2
    while len(tokens) < 2 and offset < min(len(data), 4096):
        byte = data[offset:offset + 1]
        if byte == b'#':
            end = data.find(b'\n', offset)
            offset = len(data) if end < 0 else end + 1
        elif byte.isspace():
            offset += 1
        else:
            end = offset
            while end < len(data) and data[end:end + 1].isdigit():
                end += 1
            if end == offset:
                return 0, 0, False
            tokens.append(data[offset:end])
            offset = end
    if len(tokens) < 2:
        return 0, 0, False
    return int(tokens[0]), int(tokens[1]), True     # PNM has no end marker: the decoder checks the rest


def image_header(data: bytes) -> tuple[str, int, int, bool] | None:
    """(format, width, height, complete) from an image file's header; None for an unknown format.
    ``complete`` is False when the file lacks the end a whole file of that format has."""
    if data.startswith(b'\x89PNG\r\n\x1a\n'):
        return ('PNG', *_png_size(data))
    if data.startswith(b'\xff\xd8'):
        return ('JPEG', *_jpeg_size(data))
    if data.startswith(b'BM'):
        return ('BMP', *_bmp_size(data))
    if len(data) > 2 and data[:1] == b'P' and data[1:2] in b'123456':
        return ('PNM', *_pnm_size(data))
    return None


def read_image_bytes(path: Any, what: str = 'image file', error: ErrorType = ConfigurationError,
                     max_pixels: int = MAX_IMAGE_PIXELS) -> tuple[bytes, int, int]:
    """(the file's bytes, width, height) of an image whose header shows a size within ``max_pixels``;
    decode the bytes with an image module (``cv2.imdecode``) and compare the size."""
    data = read_file_bytes(path, what, error, MAX_IMAGE_BYTES)
    where = _where(path, what)
    header = image_header(data)
    if header is None:
        raise error(f'{where}: not {IMAGE_FORMATS}')
    kind, width, height, complete = header
    if width <= 0 or height <= 0:
        raise error(f'{where}: {kind} header without a valid size')
    if width * height > max_pixels:
        raise error(f'{where}: {width} x {height} pixels (at most {max_pixels} pixels)')
    if not complete:
        raise error(f'{where}: truncated {kind} file')
    return data, width, height
