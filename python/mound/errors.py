"""The project's error types, one module for all (../shared/STYLE.md).

- InputError: bad input the user can fix; the message names the file, line or field.
  The `mound` CLI answers it with exit 2 and that one line.
- NoResultError: the input was valid but allowed no result (a scene with no motion or no
  texture, too few registered images); exit 3, and the result file says `status: failed`.
- ToolError: one of the project's C++ tools failed; carries the tool name, its exit code
  and the tail of its stderr. Exit 2 and 3 of a tool arrive as ToolInputError and
  ToolNoResultError, which are also InputError and NoResultError, so that callers handle
  "bad input" alike wherever it was found.
"""

from __future__ import annotations

import contextlib
import logging
import signal
import sys
import warnings
from collections.abc import Iterator

EXIT_OK = 0
EXIT_INTERNAL = 1
EXIT_BAD_INPUT = 2
EXIT_NO_RESULT = 3


class MoundError(Exception):
    """Base of the project's own errors."""


class InputError(MoundError, ValueError):
    """Bad input the user can fix; the message names the file, line or field."""


class NoResultError(MoundError):
    """Valid input that allowed no result."""


def describe_exit(code: int) -> str:
    """Words for a tool's exit status (negative: killed by that signal, as subprocess says;
    128+N: killed by signal N, as a shell says)."""
    if code == EXIT_BAD_INPUT:
        return "exit 2: bad input"
    if code == EXIT_INTERNAL:
        return "exit 1: internal error"
    if code == EXIT_NO_RESULT:
        return "exit 3: no result"
    signal_number = -code if code < 0 else code - 128 if code > 128 else 0
    if signal_number == signal.SIGKILL:
        return f"exit {code}: killed (out of memory?)"
    if signal_number in (signal.SIGABRT, signal.SIGSEGV):
        return f"exit {code}: crashed (signal {signal_number})"
    if signal_number == signal.SIGINT:
        return f"exit {code}: interrupted"
    if signal_number:
        return f"exit {code}: killed by signal {signal_number}"
    return f"exit {code}"


class ToolError(MoundError, RuntimeError):
    """A project tool failed; `code` is its exit status (negative: killed by a signal)."""

    def __init__(self, tool: str, code: int, stderr: str) -> None:
        self.tool = tool
        self.code = code
        self.stderr = stderr
        self.tail = "\n".join(stderr.strip().splitlines()[-10:])
        super().__init__(f"{tool} failed ({describe_exit(code)}): {self.tail}")


class ToolInputError(ToolError, InputError):
    """A tool refused its input (exit 2)."""


class ToolNoResultError(ToolError, NoResultError):
    """A tool found that its valid input allowed no result (exit 3)."""


class ToolTimeout(ToolError):
    """A tool ran past its time limit and was ended."""


def tool_error(tool: str, code: int, stderr: str) -> ToolError:
    """The error type for a tool's non-zero exit status."""
    if code == EXIT_BAD_INPUT:
        return ToolInputError(tool, code, stderr)
    if code == EXIT_NO_RESULT:
        return ToolNoResultError(tool, code, stderr)
    return ToolError(tool, code, stderr)


EXIT_INTERRUPTED = 130  # Ctrl-C (128 + SIGINT), as a shell reports it
EXIT_TERMINATED = 143   # SIGTERM (128 + SIGTERM)


class Terminated(KeyboardInterrupt):
    """SIGTERM (a scheduler's or CI's stop), taken as Ctrl-C: the tools end, nothing new
    starts, and the command stops with EXIT_TERMINATED (native.sigterm_as_interrupt)."""


def exit_on_interrupt(prog: str, e: KeyboardInterrupt, resume: str = "") -> int:
    """A command line's answer to Ctrl-C or SIGTERM: one line, 130 or 143."""
    what = "terminated (SIGTERM)" if isinstance(e, Terminated) else "interrupted"
    print(f"\n{prog}: {what}{'; ' + resume if resume else ''}", file=sys.stderr)
    return EXIT_TERMINATED if isinstance(e, Terminated) else EXIT_INTERRUPTED


def exit_for(prog: str, e: Exception) -> int:
    """A command line's answer to an error that reached its main: one line on stderr and
    the exit code (2 bad input, 3 no result, 1 anything else: a bug)."""
    if isinstance(e, InputError):
        print(f"{prog}: {e}", file=sys.stderr)
        return EXIT_BAD_INPUT
    if isinstance(e, NoResultError):
        print(f"{prog}: no result: {e}", file=sys.stderr)
        return EXIT_NO_RESULT
    print(f"{prog}: internal error (a bug, please report): {e!r}", file=sys.stderr)
    return EXIT_INTERNAL


@contextlib.contextmanager
def library_warnings(log: logging.Logger) -> Iterator[None]:
    """The warnings of the libraries called in the block (rasterio's NotGeoreferencedWarning,
    GDAL's odd tags): issued as usual when the block succeeds; when it raises, only logged,
    so that stderr gets the error's one line."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            yield
        except BaseException:
            for w in caught:
                log.info("%s: %s", w.category.__name__, w.message)
            raise
    for w in caught:
        warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
