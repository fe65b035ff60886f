"""The pieces of the HTML report: its stylesheet, escaping, numbers, tables and figures
embedded as PNG data URIs.
"""

from __future__ import annotations

import base64
import contextlib
import contextvars
import html
import io
import math
import os
import re
import select
import signal
import warnings
from collections.abc import Callable, Iterator, Sequence
from typing import Any

__all__ = [
    "CSS",
    "Aside",
    "Num",
    "Raw",
    "deferred",
    "esc",
    "img",
    "num",
    "render_deferred",
    "row",
    "table",
]

PathLike = str | os.PathLike[str]

CSS = """
body { font-family: "DejaVu Sans", Helvetica, Arial, sans-serif; color: #222;
       max-width: 1180px; margin: 1.5em auto; padding: 0 1em; line-height: 1.4; }
h1 { font-size: 1.6em; border-bottom: 3px solid #1f77b4; padding-bottom: .2em; }
h2 { font-size: 1.25em; margin-top: 2em; border-bottom: 1px solid #ccc; }
h3 { font-size: 1.05em; margin-bottom: .3em; }
table { border-collapse: collapse; margin: .5em 0 1em 0; font-size: .9em; display: block;
        overflow-x: auto; max-width: 100%; }
th, td { border: 1px solid #ccc; padding: .25em .6em; text-align: left; vertical-align: top; }
th { background: #f0f3f7; }
td.num { text-align: right; font-variant-numeric: tabular-nums; white-space: nowrap; }
span.num { font-variant-numeric: tabular-nums; white-space: nowrap; }
tr.hl td { background: #fff4d6; font-weight: bold; }
.row { display: flex; flex-wrap: wrap; gap: 1.5em; align-items: flex-start; }
.row > div { flex: 0 1 auto; max-width: 100%; overflow-x: auto; }
.row > figure { flex: 1 1 520px; }
figure.narrow { max-width: 820px; }
figure { margin: .5em 0; }
figure img { max-width: 100%; height: auto; border: 1px solid #ddd; }
figcaption { font-size: .85em; color: #555; }
.verdict { display: inline-block; padding: .2em .8em; border-radius: .3em; font-weight: bold;
           font-size: 1.15em; }
.missing { background: #d62728; color: white; }
.adequate { background: #2ca02c; color: white; }
.unexplained { background: #9467bd; color: white; }
.note { color: #555; font-size: .9em; }
.warn { color: #8c3b00; }
code { background: #f4f4f4; padding: 0 .2em; }
p.answer { font-size: 1.1em; }
h2.part { margin-top: 3em; border-bottom: 3px solid #1f77b4; }
pre { background: #f7f7f7; padding: .6em; font-size: .8em; overflow-x: auto; }
footer { margin-top: 3em; font-size: .8em; color: #777; }
"""


# ---------------------------------------------------------------------------- formatting
def esc(text: Any) -> str:
    return html.escape(str(text), quote=True)


def num(x: float, digits: int = 4) -> str:
    """A computed number to ``digits`` significant figures, trailing zeros kept so that a
    column reads alike (``0.00030`` beside ``0.00033``), one formatter with the terminal
    (:func:`eodarm.viz.format.value`); ``∞`` and ``–`` for what is not a number."""
    from eodarm.viz.format import value

    if x is None or not math.isfinite(x):
        return "∞" if x is not None and x > 0 else "–"
    return value(x, digits=digits, zeros=True)


def table(head: Sequence[str], rows: Sequence[Sequence[Any]], hl: Sequence[bool] = ()) -> str:
    """An HTML table; cells are escaped unless given as ``Raw``; numbers right-aligned.

    Without a ``head`` the first column is a column of row headings (a key/value table).
    """
    out = ["<table>"]
    if head:
        out.append("<tr>" + "".join(f"<th>{esc(h)}</th>" for h in head) + "</tr>")
    for i, row in enumerate(rows):
        cls = ' class="hl"' if i < len(hl) and hl[i] else ""
        cells = []
        for j, cell in enumerate(row):
            if not head and j == 0:
                cells.append(f"<th>{esc(cell)}</th>")
            elif isinstance(cell, Raw):
                cells.append(f"<td>{cell.html}</td>")
            elif isinstance(cell, Num):
                cells.append(f'<td class="num">{esc(cell.text)}</td>')
            else:
                cells.append(f"<td>{esc(cell)}</td>")
        out.append(f"<tr{cls}>" + "".join(cells) + "</tr>")
    out.append("</table>")
    return "\n".join(out)


class Raw:
    """Trusted HTML for a table cell."""

    def __init__(self, text: str) -> None:
        self.html = text


class Num:
    """A right-aligned number cell."""

    def __init__(self, x: float, digits: int = 4, suffix: str = "") -> None:
        self.text = num(x, digits) + suffix


#: Figures of :func:`img` waiting to be rendered by :func:`render_deferred` (None: render at
#: once).
_PENDING: contextvars.ContextVar[list[Any] | None] = contextvars.ContextVar(
    "eodarm_pending_figures", default=None
)

_MARK = re.compile("\x00fig(\\d+)\x00")


def png_base64(fig: Any) -> str:
    """A figure as base64 PNG at 120 dpi (fast zlib level: the page is written once)."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=120, pil_kwargs={"compress_level": 1})
    return base64.b64encode(buf.getvalue()).decode("ascii")


def img(fig: Any, alt: str, caption: str, narrow: bool = False) -> str:
    """A figure as an embedded PNG (base64) with a caption. Inside :func:`deferred`, the PNG
    is a placeholder until :func:`render_deferred` draws every figure of the page."""
    pending = _PENDING.get()
    if pending is None:
        data = png_base64(fig)
    else:
        pending.append(fig)
        data = f"\x00fig{len(pending) - 1}\x00"
    cls = ' class="narrow"' if narrow else ""
    return (
        f"<figure{cls}>"
        f'<img src="data:image/png;base64,{data}" alt="{esc(alt)}">'
        f"<figcaption>{esc(caption)}</figcaption></figure>"
    )


@contextlib.contextmanager
def deferred() -> Iterator[list[Any]]:
    """Collect the figures of :func:`img` instead of drawing each at once."""
    figs: list[Any] = []
    token = _PENDING.set(figs)
    try:
        yield figs
    finally:
        _PENDING.reset(token)


def render_deferred(text: str, figs: Sequence[Any], parallel: bool = True) -> str:
    """Draw the collected figures and put them in place of their placeholders.

    Drawing is most of a page's time and every figure is independent: with ``parallel`` and
    two or more CPUs, a forked child draws about half of them (by panels) while this process
    draws the others. The PNGs are the same either way; if the child fails or is silent for
    120 s, its figures are drawn here.
    """
    pngs = _render_all(list(figs), parallel)
    return _MARK.sub(lambda m: pngs[int(m[1])], text)


#: Whether pages may be drawn on two processes (tests switch it off to compare).
PARALLEL = True


def _can_fork(parallel: bool) -> bool:
    return PARALLEL and parallel and hasattr(os, "fork") and (os.cpu_count() or 1) >= 2


class Aside:
    """``fn()`` (returning text) run in a forked child while this process goes on; calling
    the object gives its result. Without two CPUs or ``fork``, or if the child fails or is
    silent for 120 s, ``fn()`` runs here when called: the text is the same either way.
    Inside the child, :func:`img` draws at once (nothing is deferred to this process)."""

    def __init__(self, fn: Callable[[], str], parallel: bool = True) -> None:
        self.fn = fn
        self.pid, self.fd = -1, -1
        if not _can_fork(parallel):
            return
        try:
            fd, wfd = os.pipe()
            with warnings.catch_warnings():
                # Python ≥ 3.12 warns on fork() in a process with threads (the core's rayon
                # pool); the child only draws finished figures and never touches the core.
                warnings.filterwarnings("ignore", category=DeprecationWarning, message=".*fork")
                pid = os.fork()
        except OSError:
            return
        if pid == 0:  # the child: do the work, send it, leave without any cleanup
            code = 0
            try:
                os.close(fd)
                _PENDING.set(None)
                data = fn().encode("utf-8")
                with os.fdopen(wfd, "wb") as w:
                    w.write(data)
            except BaseException:
                code = 1
            os._exit(code)
        os.close(wfd)
        self.pid, self.fd = pid, fd

    @property
    def forked(self) -> bool:
        return self.pid > 0

    def __call__(self) -> str:
        if self.forked:
            data = _read_child(self.fd, self.pid)
            self.pid = -1
            if data is not None:
                return data.decode("utf-8")
        return self.fn()


def _render_all(figs: list[Any], parallel: bool) -> list[str]:
    # Split the work evenly: a figure's drawing time grows with its panels (axes), so the
    # figures go, largest first, to whichever side has less so far.
    load = [0, 0]
    sides: list[list[int]] = [[], []]
    for i in sorted(range(len(figs)), key=lambda i: -len(figs[i].axes)):
        side = 0 if load[0] <= load[1] else 1
        sides[side].append(i)
        load[side] += len(figs[i].axes) + 1
    mine, theirs = sorted(sides[0]), sorted(sides[1])
    if len(figs) < 2 or not theirs:
        return [png_base64(f) for f in figs]
    aside = Aside(lambda: "\n".join(png_base64(figs[i]) for i in theirs), parallel)
    out: dict[int, str] = {i: png_base64(figs[i]) for i in (mine if aside.forked else ())}
    got = aside().split("\n")
    if len(got) == len(theirs):
        out.update(zip(theirs, got, strict=True))
    return [out[i] if i in out else png_base64(figs[i]) for i in range(len(figs))]


def _read_child(fd: int, pid: int, timeout: float = 120.0) -> bytes | None:
    """What the child wrote, or None if it failed or stayed silent for ``timeout`` s."""
    chunks = []
    ok = True
    with os.fdopen(fd, "rb") as r:
        while True:
            ready, _, _ = select.select([r], [], [], timeout)
            if not ready:
                ok = False
                with contextlib.suppress(OSError):
                    os.kill(pid, signal.SIGKILL)
                break
            chunk = r.read1(1 << 20)
            if not chunk:
                break
            chunks.append(chunk)
    _, status = os.waitpid(pid, 0)
    if not ok or status != 0:
        return None
    return b"".join(chunks)


def row(left: str, right: str) -> str:
    return f'<div class="row"><div>{left}</div>{right}</div>'
