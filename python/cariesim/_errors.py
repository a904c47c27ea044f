"""cariesim.Error: every problem the library reports, with its location read out of the message.

The library's messages name where the problem is (docs/scene-format.md): ``FILE:LINE:COLUMN: FIELD:
MESSAGE`` for a file, ``FILE (override KEY): FIELD: MESSAGE`` for a parameter override, ``trajectory
row N: MESSAGE`` for an array row. The attributes hold those parts (None when absent).
"""

import re

_LOCATED = re.compile(r"^(?P<file>.+?):(?P<line>\d+):(?P<column>\d+): (?P<rest>.*)$", re.S)
_OVERRIDE = re.compile(r"^(?P<file>.+?) \(override (?P<override>[^)]*)\): (?P<rest>.*)$", re.S)
_ROW = re.compile(r"^(?P<what>\w[\w ]*?) row (?P<row>\d+): (?P<rest>.*)$", re.S)
_FIELD = re.compile(r"^(?P<field>[A-Za-z_][\w-]*(?:\[\d+\]|\.[A-Za-z_][\w-]*)*): (?P<message>.*)$", re.S)


class Error(ValueError):
    """A problem in what was given: a scene, an override, an array, a file.

    Attributes: ``file``, ``line``, ``column`` (1-based), ``field`` (e.g. ``lesions[0].material.k_c``),
    ``override`` (the override's key when the problem is in one), ``row`` (an array's row, from 0) and
    ``message`` (the rest); each None when the message does not name it.
    """

    def __init__(self, text):
        super().__init__(text)
        self.file = self.line = self.column = self.field = self.override = self.row = None
        rest = text
        m = _OVERRIDE.match(text)
        if m:
            self.file, self.override, rest = m.group("file"), m.group("override"), m.group("rest")
        else:
            m = _LOCATED.match(text)
            if m:
                self.file, rest = m.group("file"), m.group("rest")
                self.line, self.column = int(m.group("line")), int(m.group("column"))
            else:
                m = _ROW.match(text)
                if m:
                    self.row, rest = int(m.group("row")), m.group("rest")
        m = _FIELD.match(rest)
        if m and (self.file is not None or self.override is not None):
            self.field, rest = m.group("field"), m.group("message")
        self.message = rest
