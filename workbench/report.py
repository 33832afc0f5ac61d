"""A small report document: headings, text, tables and images, written as Markdown and HTML.

The demo fills a :class:`Report` section by section; :meth:`Report.write`
renders both ``report.md`` and ``report.html`` (images are linked by relative
path, so the output folder can be moved or zipped as a whole).
"""

from __future__ import annotations

import html
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

from model.files import write_atomic

__all__ = ["Report", "format_number"]


def format_number(x: Any, digits: int = 4) -> str:
    """A compact, readable number: 4 significant digits, exponent only when needed."""
    if isinstance(x, str):
        return x
    if isinstance(x, bool) or x is None:
        return str(x)
    if isinstance(x, int):
        return str(x)
    value = float(x)
    if value != value or value in (float("inf"), float("-inf")):
        return str(value)
    if value == 0.0:
        return "0"
    if 1e-3 <= abs(value) < 1e5:
        return f"{value:.{digits}g}"
    return f"{value:.{digits - 1}e}"


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
        self.blocks.append(_Block("heading", (level, text)))

    def text(self, text: str) -> None:
        self.blocks.append(_Block("text", text))

    def code(self, text: str) -> None:
        self.blocks.append(_Block("code", text))

    def table(self, header: Sequence[str], rows: Sequence[Sequence[Any]]) -> None:
        cells = [[format_number(c) for c in row] for row in rows]
        self.blocks.append(_Block("table", ([str(h) for h in header], cells)))

    def image(self, path: str | Path, caption: str) -> None:
        """An image, given by its path relative to the report's folder."""
        self.blocks.append(_Block("image", (Path(path).as_posix(), caption)))

    # ----------------------------------------------------------------- render
    def to_markdown(self) -> str:
        out = [f"# {self.title}", ""]
        for block in self.blocks:
            if block.kind == "heading":
                level, text = block.data
                out += ["#" * level + " " + text, ""]
            elif block.kind == "text":
                out += [block.data, ""]
            elif block.kind == "code":
                out += ["```", block.data.rstrip(), "```", ""]
            elif block.kind == "table":
                header, rows = block.data
                out.append("| " + " | ".join(header) + " |")
                out.append("|" + "---|" * len(header))
                out += ["| " + " | ".join(row) + " |" for row in rows]
                out.append("")
            elif block.kind == "image":
                path, caption = block.data
                out += [f"![{caption}]({path})", "", f"*{caption}*", ""]
        return "\n".join(out)

    def to_html(self) -> str:
        esc = html.escape
        body = [f"<h1>{esc(self.title)}</h1>"]
        for block in self.blocks:
            if block.kind == "heading":
                level, text = block.data
                body.append(f"<h{level}>{esc(text)}</h{level}>")
            elif block.kind == "text":
                body.append(f"<p>{esc(block.data)}</p>")
            elif block.kind == "code":
                body.append(f"<pre>{esc(block.data)}</pre>")
            elif block.kind == "table":
                header, rows = block.data
                head = "".join(f"<th>{esc(h)}</th>" for h in header)
                lines = "".join("<tr>" + "".join(f"<td>{esc(c)}</td>" for c in row) + "</tr>" for row in rows)
                body.append(f"<table><thead><tr>{head}</tr></thead><tbody>{lines}</tbody></table>")
            elif block.kind == "image":
                path, caption = block.data
                body.append(f'<figure><img src="{esc(path)}" alt="{esc(caption)}"><figcaption>{esc(caption)}</figcaption></figure>')
        style = (
            "body{font-family:sans-serif;max-width:70em;margin:2em auto;padding:0 1em;color:#222}"
            "table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #bbb;padding:.25em .6em;text-align:right}"
            "th{background:#eee}img{max-width:100%}figure{margin:1em 0}figcaption{color:#555;font-size:.9em}"
            "pre{background:#f6f6f6;padding:.6em;overflow-x:auto}"
        )
        return (f"<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>{esc(self.title)}</title>"
                f"<style>{style}</style></head><body>\n" + "\n".join(body) + "\n</body></html>\n")

    def write(self, folder: str | Path, stem: str = "report") -> tuple[Path, Path]:
        """Write ``stem.md`` and ``stem.html`` into ``folder``; returns both paths."""
        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        md, htm = folder / f"{stem}.md", folder / f"{stem}.html"
        write_atomic(md, self.to_markdown())
        write_atomic(htm, self.to_html())
        return md, htm
