"""Exceptions the tool reports to users as one line (`nfc: error: <message>`), never as a traceback."""

from __future__ import annotations

FORMAT_ERROR_KINDS = ("truncated", "corrupt", "unsupported_version", "unsupported_feature")


class NfcError(Exception):
    """Base of every error nfc reports to a user. The message is a single line."""

    def __init__(self, message: str) -> None:
        super().__init__(" ".join(str(message).split()))

    @property
    def message(self) -> str:
        return str(self.args[0])


class InputError(NfcError):
    """An input file or value the tool cannot use (missing, unreadable, empty, NaN, degenerate...)."""


class DeviceError(InputError):
    """The requested device is not available on this machine (e.g. `--device cuda` without a GPU):
    unlike other input errors, it depends on where the command runs, not on the input."""


class FormatError(NfcError):
    """A `.nfc` byte stream a reader must reject. `kind` is one of FORMAT.md's error classes."""

    def __init__(self, kind: str, message: str) -> None:
        if kind not in FORMAT_ERROR_KINDS:
            raise ValueError(f"unknown format error kind {kind!r}")
        self.kind = kind
        self.detail = " ".join(str(message).split())
        super().__init__(f"{kind.replace('_', ' ')} .nfc file: {self.detail}")

    def __reduce__(self):  # type: ignore[override]  # keep picklable despite the 2-argument init
        return (FormatError, (self.kind, self.detail))
