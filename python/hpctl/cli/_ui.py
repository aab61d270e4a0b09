"""What every command shares: output (tables, progress, warnings,
errors), JSON conversion, exit codes, and the options every command has.

Everything a command prints that comes from outside the program (paths,
record names, messages that quote a user's file) is printed as rich
``Text``, never as markup: ``[static]`` must survive and a ``[/x]`` in a
user's cell must not crash the printer."""

from __future__ import annotations

import math
import os
import sys
import traceback
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click
from rich.console import Console
from rich.text import Text

from hpctl.caveats import Caveat
from hpctl.caveats import to_json as caveats_json
from hpctl.data import output
from hpctl.errors import HpctlError
from hpctl.model.unit import Unit

if TYPE_CHECKING:
    from rich.table import Table

#: Where the root command keeps the arguments it was given (click's
#: context ``meta``), for :func:`invocation`.
ARGS_KEY = "hpctl.args"

#: Exit codes: 0 ok; 1 internal error or the environment failed (an
#: output that cannot be written: disk full, no permission); 2 bad input
#: (usage, parameters, records, an output folder that cannot be used as
#: asked); 3 warnings under --strict (the outputs are written, warnings
#: included); 130 interrupted (Ctrl-C; the previous outputs are kept).
EXIT_OK, EXIT_INTERNAL, EXIT_BAD_INPUT, EXIT_WARNINGS, EXIT_INTERRUPTED = 0, 1, 2, 3, 130


class Reporter:
    """Progress bars and human output on stderr/stdout, silenced by
    ``--quiet``; ``--json`` keeps stdout for the JSON document alone."""

    def __init__(self, quiet: bool, as_json: bool) -> None:
        self.quiet = quiet
        self.as_json = as_json
        self.out = Console(quiet=quiet or as_json, width=console_width(sys.stdout.isatty(), os.environ))
        self.err = Console(stderr=True, quiet=quiet)
        # Errors are printed even with --quiet.
        self.errors = Console(stderr=True)

    @contextmanager
    def bars(self) -> Iterator[Callable[[str], Callable[[int, int], None] | None]]:
        """A factory of progress callbacks, one bar per simulation. Bars
        appear only for runs that report progress (longer than ~0.1 s)."""
        if self.quiet:
            yield lambda _name: None
            return
        from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn

        with Progress(
            TextColumn("{task.description}"), BarColumn(), TextColumn("{task.percentage:>3.0f}%"), TimeRemainingColumn(),
            console=self.err, transient=True,
        ) as progress:

            def make(name: str) -> Callable[[int, int], None]:
                task = progress.add_task(name, total=None)

                def update(done: int, total: int) -> None:
                    progress.update(task, completed=done, total=total)

                return update

            yield make

    def say(self, *parts: str | tuple[str, str]) -> None:
        """A line of human output on stdout (nothing with --quiet or
        --json), as text: parts are plain strings or (text, style)."""
        self.out.print(Text.assemble(*parts), soft_wrap=True, highlight=False)

    def note(self, *parts: str | tuple[str, str]) -> None:
        """A line of human output on stderr (nothing with --quiet)."""
        self.err.print(Text.assemble(*parts), soft_wrap=True, highlight=False)

    def warn(self, caveats: Sequence[Caveat]) -> None:
        """Prints warnings on stderr (even with --quiet: they are part of
        the result, like errors)."""
        for c in caveats:
            self.errors.print(Text.assemble(("warning", "yellow"), f" [{c.code}]: ", c.message), soft_wrap=True, highlight=False)


def console_width(is_terminal: bool, environ: Mapping[str, str]) -> int | None:
    """The width tables are laid out for: the terminal's (None: rich asks
    it, and honours ``COLUMNS``); written to a file or a pipe, ``COLUMNS``
    if set, else 160 (wide enough for every table, no wrapping in logs)."""
    if is_terminal:
        return None
    try:
        columns = int(environ.get("COLUMNS", ""))
    except ValueError:
        return 160
    return columns if columns > 0 else 160


def table(title: str, columns: Iterable[str], *, justify: str = "right") -> Table:
    """A table that fits the console it is printed on: the first column
    (the row's name) left-aligned, the others right-aligned. In a narrow
    terminal the headers wrap at their spaces (or break), but a cell keeps
    its width, up to 12 characters, so numbers stay whole; a longer cell
    folds onto a second line instead of being cut with an ellipsis: no
    digit is lost."""
    from rich import box
    from rich.table import Table

    class _Fitting(Table):
        def add_row(self, *cells: Any, **kwargs: Any) -> None:
            super().add_row(*cells, **kwargs)
            for column, cell in zip(self.columns, cells):
                width = len(cell.plain if isinstance(cell, Text) else str(cell))
                column.min_width = max(column.min_width or 0, min(width, 12))

    # No vertical lines: in a narrow terminal every character goes to the cells.
    t = _Fitting(title=title, box=box.SIMPLE_HEAD, show_edge=False, pad_edge=False, collapse_padding=True, title_justify="left")
    for k, name in enumerate(columns):
        t.add_column(name, justify="left" if k == 0 else justify, overflow="fold")  # type: ignore[arg-type]
    return t


def invocation() -> list[str]:
    """The command line this process was given, as ``hpctl ARGS...`` (the
    arguments the root command parsed; outside click, ``sys.argv``)."""
    ctx = click.get_current_context(silent=True)
    args = None if ctx is None else ctx.find_root().meta.get(ARGS_KEY)
    return ["hpctl", *(sys.argv[1:] if args is None else args)]


def provenance() -> dict[str, str]:
    """hpctl's version and the exact command, for every summary and report
    (:func:`hpctl.data.output.provenance`)."""
    return output.provenance(invocation())


def output_dir(root: Path, command: str, *, force: bool = False, protect: Iterable[str] = ()) -> output.OutputDir:
    """The output folder of a command, knowing who writes it (its reports
    carry :func:`provenance`)."""
    return output.OutputDir(root, command, force=force, protect=protect, provenance=provenance())


def finish(rep: Reporter, caveats: Sequence[Caveat], strict: bool) -> None:
    """The end of a command whose outputs are written: the warnings on
    stderr, and with ``--strict`` exit code 3 if there are any."""
    rep.warn(caveats)
    if caveats and strict:
        rep.errors.print(Text(f"{len(caveats)} warning(s) and --strict: exit code {EXIT_WARNINGS}"), soft_wrap=True, highlight=False)
        sys.exit(EXIT_WARNINGS)


def with_warnings(summary: dict[str, Any], caveats: Sequence[Caveat]) -> dict[str, Any]:
    """The summary as JSON data, led by who wrote it (``"hpctl"``: the
    version and the exact command) and ending with its ``"warnings"`` list."""
    document: dict[str, Any] = jsonable({"hpctl": provenance(), **summary, "warnings": caveats_json(caveats)})
    return document


def strict_option(f: Callable[..., Any]) -> Callable[..., Any]:
    return click.option("--strict", is_flag=True, help=f"Exit with code {EXIT_WARNINGS} if there is any warning (the outputs are still written).")(f)


#: The figure formats (:data:`hpctl.report.plots.FORMATS`; repeated here so
#: that the option does not import matplotlib at start-up: a test keeps
#: the two equal).
FIGURE_FORMATS = ("png", "svg", "pdf")


def format_option(f: Callable[..., Any]) -> Callable[..., Any]:
    return click.option("--format", "fig_format", type=click.Choice(FIGURE_FORMATS), default="png", show_default=True,
                        help="File format of the plots.")(f)


def force_option(f: Callable[..., Any]) -> Callable[..., Any]:
    return click.option("--force", is_flag=True,
                        help="Overwrite files in the output folder that hpctl did not write (or that were changed since).")(f)


class FiniteFloat(click.ParamType):  # type: ignore[type-arg]
    """A finite number (NaN and infinities refused), optionally within a
    range: click's FLOAT and FloatRange let NaN through (every comparison
    with NaN is false)."""

    name = "number"

    def __init__(self, lo: float | None = None, hi: float | None = None) -> None:
        self.lo, self.hi = lo, hi

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> float:
        try:
            v = float(value)
        except (TypeError, ValueError):
            self.fail(f"{value!r} is not a number", param, ctx)
        if not math.isfinite(v):
            self.fail(f"{value!r} is not a finite number", param, ctx)
        if (self.lo is not None and v < self.lo) or (self.hi is not None and v > self.hi):
            lo = "-inf" if self.lo is None else f"{self.lo:g}"
            hi = "inf" if self.hi is None else f"{self.hi:g}"
            self.fail(f"{v:g} is not within [{lo}, {hi}]", param, ctx)
        return v


FINITE = FiniteFloat()


class _Status:
    """A spinner with a changing message, for work without a known total."""

    def __init__(self, rep: Reporter, message: str) -> None:
        self._console = rep.err
        self._status = None if rep.quiet else rep.err.status(message)

    def __enter__(self) -> _Status:
        if self._status is not None:
            self._status.__enter__()
        return self

    def __exit__(self, *exc: object) -> None:
        if self._status is not None:
            self._status.__exit__(None, None, None)

    def update(self, message: str) -> None:
        if self._status is None:
            return
        self._status.update(message)
        if not self._console.is_terminal:
            # No spinner where stderr is a file or a pipe (a log, CI):
            # each update as a line, so that progress is seen there too.
            self._console.print(Text(message), highlight=False, soft_wrap=True)


def status(rep: Reporter, message: str) -> _Status:
    """A spinner on stderr (nothing with --quiet)."""
    return _Status(rep, message)



def jsonable(x: Any) -> Any:
    if isinstance(x, float) and not math.isfinite(x):
        return None
    if isinstance(x, dict):
        return {k: jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [jsonable(v) for v in x]
    return x


def fmt(v: Any, scale: float = 1.0, digits: int = 2) -> str:
    return "-" if v is None else f"{v * scale:.{digits}f}"



def load_unit(unit_file: Path | None, tau_s: float | None, gas: str | None) -> Unit:
    unit = Unit.seed() if unit_file is None else Unit.from_toml(unit_file)
    if tau_s is not None:
        unit = unit.replace(tau_s=tau_s)
    if gas is not None:
        unit = unit.replace(gas=gas)
    unit.check()
    return unit



def modes(option: str, names: tuple[str, str]) -> list[bool]:
    """'both' -> [True, False]; otherwise the one state (True = first name)."""
    return [True, False] if option == "both" else [option == names[0]]



def parse_tau(value: str | None) -> float | None:
    if value is None:
        return None
    try:
        return float(value)
    except ValueError:
        raise click.BadParameter(f"{value!r} is not a number (seconds; 0 = isothermal, inf = adiabatic)") from None



def parse_floats(text: str | None, option: str) -> list[float] | None:
    if text is None:
        return None
    try:
        return [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise click.BadParameter(f"{text!r}: expected comma-separated numbers", param_hint=option) from None



@contextmanager
def errors(rep: Reporter) -> Iterator[None]:
    """Bad input -> message and exit 2; anything else -> exit 1."""
    try:
        yield
    except (click.ClickException, click.exceptions.Exit, click.exceptions.Abort):
        raise
    except HpctlError as e:
        # A message is data, never markup: "[static]" must survive, and a
        # "[/x]" in a user's file must not crash the printer. No hard wrap:
        # paths stay whole for whoever greps the output.
        rep.errors.print(Text.assemble(("error: ", "red"), str(e)), soft_wrap=True, highlight=False)
        sys.exit(EXIT_BAD_INPUT)
    except KeyboardInterrupt:
        rep.errors.print(Text("interrupted; the previous outputs are kept"), soft_wrap=True, highlight=False)
        sys.exit(EXIT_INTERRUPTED)
    except OSError as e:
        # The environment, not the input: a disk full, a folder that
        # cannot be created, no permission.
        notes = "".join(f"; {n}" for n in getattr(e, "__notes__", ()))
        what = f"{e.filename}: {e.strerror}" if e.filename and e.strerror else str(e)
        rep.errors.print(Text.assemble(("error: ", "red"), f"{what}{notes}"), soft_wrap=True, highlight=False)
        sys.exit(EXIT_INTERNAL)
    except Exception as e:  # noqa: BLE001 - the last line of defence
        rep.errors.print(Text.assemble(("internal error: ", "red"), f"{type(e).__name__}: {e}"), soft_wrap=True, highlight=False)
        if rep.errors.is_terminal:
            traceback.print_exc()
        sys.exit(EXIT_INTERNAL)

