"""A small report document: headings, text, tables, figures and long text, written as Markdown and HTML.

The demo fills a :class:`Report` section by section (:mod:`workbench.sections`:
one function per section); :meth:`Report.write` renders ``report.md`` and
``report.html``. Images are linked by their path relative to the report's
folder, so the output folder can be moved or zipped as a whole.

Text may hold inline code between backticks (```manip demo```): Markdown keeps
it, HTML renders it as ``<code>``. Every number column of a table has one format
(:func:`workbench.formatting.format_column`); text columns are left-aligned,
number columns right-aligned.
"""

from __future__ import annotations

import html
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

from model.files import write_atomic

from .formatting import table_cells

__all__ = ["Report", "inline_html"]

_CODE = re.compile(r"`([^`]+)`")

_STYLE = (
    "body{font-family:system-ui,sans-serif;max-width:82em;margin:2em auto;padding:0 1.2em;color:#222;line-height:1.4}"
    "h1{font-size:1.7em}h2{margin-top:1.8em;border-bottom:1px solid #ddd;padding-bottom:.2em}"
    "table{border-collapse:collapse;margin:.8em 0}td,th{border:1px solid #ccc;padding:.25em .6em}"
    "th{background:#f0f0f0;font-weight:600}td.num{text-align:right;font-variant-numeric:tabular-nums}"
    "td.text{text-align:left}th.num{text-align:right}th.text{text-align:left}"
    "code{background:#f2f2f2;padding:0 .25em;border-radius:3px;font-size:.92em}"
    "pre{background:#f6f6f6;padding:.6em .8em;overflow-x:auto;font-size:.85em}"
    "pre.wrap{white-space:pre-wrap;overflow-wrap:anywhere}"
    "details{margin:.6em 0}summary{cursor:pointer;color:#333}"
    ".grid{display:grid;grid-template-columns:repeat(auto-fill,minmax(36em,1fr));gap:1em;margin:1em 0}"
    "figure{margin:0}img{max-width:100%;height:auto}figcaption{color:#555;font-size:.9em}"
    ".ok{color:#1a7f37;font-weight:600}.fail{color:#c62828;font-weight:600}"
)


def inline_html(text: str) -> str:
    """``text`` escaped for HTML, inline code between backticks as ``<code>``."""
    parts = _CODE.split(text)  # even: plain text, odd: code
    return "".join(f"<code>{html.escape(p)}</code>" if k % 2 else html.escape(p) for k, p in enumerate(parts))


@dataclass
class _Block:
    kind: str
    data: Any


@dataclass
class Report:
    """An ordered list of blocks rendered to Markdown and HTML."""

    title: str
    blocks: list[_Block] = field(default_factory=list)

    def heading(self, text: str, level: int = 2) -> None:
        """A heading (level 2: a section, 3: a subsection)."""
        self.blocks.append(_Block("heading", (level, text)))

    def text(self, text: str) -> None:
        """A paragraph; inline code between backticks."""
        self.blocks.append(_Block("text", text))

    def code(self, text: str) -> None:
        """Preformatted text, e.g. a console table (HTML: a long line scrolls sideways, columns stay aligned)."""
        self.blocks.append(_Block("code", text))

    def details(self, summary: str, text: str) -> None:
        """Preformatted text folded under a one-line ``summary`` (HTML ``<details>``; long lines wrap, none clipped)."""
        self.blocks.append(_Block("details", (summary, text)))

    def table(self, header: Sequence[str], rows: Sequence[Sequence[Any]]) -> None:
        """A table laid out by :func:`~workbench.formatting.table_cells`: one number format per column."""
        cells, numeric = table_cells(header, rows)
        self.blocks.append(_Block("table", ([str(h) for h in header], cells, numeric)))

    def image(self, path: str | Path, caption: str) -> None:
        """One image, given by its path relative to the report's folder."""
        self.figures([(path, caption)])

    def figures(self, items: Sequence[tuple[str | Path, str]]) -> None:
        """Images side by side (as many per row as the page width holds), each ``(relative path, caption)``."""
        self.blocks.append(_Block("figures", [(Path(p).as_posix(), c) for p, c in items]))

    # ----------------------------------------------------------------- render
    def to_markdown(self) -> str:
        """The report as Markdown."""
        out = [f"# {self.title}", ""]
        for block in self.blocks:
            if block.kind == "heading":
                level, text = block.data
                out += ["#" * level + " " + text, ""]
            elif block.kind == "text":
                out += [block.data, ""]
            elif block.kind == "code":
                out += ["```", block.data.rstrip(), "```", ""]
            elif block.kind == "details":
                summary, text = block.data
                out += [f"{summary}:", "", "```", text.rstrip(), "```", ""]
            elif block.kind == "table":
                header, rows, numeric = block.data
                out.append("| " + " | ".join(header) + " |")
                out.append("|" + "".join("---:|" if num else ":---|" for num in numeric))
                out += ["| " + " | ".join(row) + " |" for row in rows]
                out.append("")
            elif block.kind == "figures":
                for path, caption in block.data:
                    out += [f"![{caption}]({path})", "", f"*{caption}*", ""]
        return "\n".join(out)

    def to_html(self) -> str:
        """The report as one self-contained HTML page (images linked by relative path)."""
        esc = html.escape
        body = [f"<h1>{inline_html(self.title)}</h1>"]
        for block in self.blocks:
            if block.kind == "heading":
                level, text = block.data
                body.append(f"<h{level}>{inline_html(text)}</h{level}>")
            elif block.kind == "text":
                body.append(f"<p>{inline_html(block.data)}</p>")
            elif block.kind == "code":
                body.append(f"<pre>{esc(block.data.rstrip())}</pre>")
            elif block.kind == "details":
                summary, text = block.data
                body.append(f'<details><summary>{inline_html(summary)}</summary>'
                            f'<pre class="wrap">{esc(text.rstrip())}</pre></details>')
            elif block.kind == "table":
                header, rows, numeric = block.data
                cls = ["num" if num else "text" for num in numeric]
                head = "".join(f'<th class="{c}">{esc(h)}</th>' for h, c in zip(header, cls))
                lines = "".join("<tr>" + "".join(f'<td class="{c}">{_cell_html(v)}</td>' for v, c in zip(row, cls))
                                + "</tr>" for row in rows)
                body.append(f"<table><thead><tr>{head}</tr></thead><tbody>{lines}</tbody></table>")
            elif block.kind == "figures":
                figs = "".join(f'<figure><img src="{esc(path)}" alt="{esc(caption)}" loading="lazy">'
                               f"<figcaption>{inline_html(caption)}</figcaption></figure>" for path, caption in block.data)
                body.append(f'<div class="grid">{figs}</div>')
        return (f"<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
                f"<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\"><title>{esc(self.title)}</title>"
                f"<style>{_STYLE}</style></head><body>\n" + "\n".join(body) + "\n</body></html>\n")

    def write(self, folder: str | Path, stem: str = "report") -> tuple[Path, Path]:
        """Write ``stem.md`` and ``stem.html`` into ``folder`` (atomically); returns both paths."""
        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        md, htm = folder / f"{stem}.md", folder / f"{stem}.html"
        write_atomic(md, self.to_markdown())
        write_atomic(htm, self.to_html())
        return md, htm


def _cell_html(text: str) -> str:
    """A table cell: ``ok`` / ``FAIL`` coloured, anything else as inline text."""
    if text in ("ok", "FAIL"):
        return f'<span class="{text.lower()}">{text}</span>'
    return inline_html(text)
