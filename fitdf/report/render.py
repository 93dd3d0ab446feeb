"""Render the comparison report from ``results.json`` (and the figure files) as Markdown and HTML.

Both renderings come from one document model -- a list of blocks (headings,
paragraphs, lists, tables, images, collapsible details) built by
:func:`fitdf.report.outline.build_document` -- so they always say the same thing:

* :func:`render_markdown` -- ``README.md``: pipe tables, relative image links
  (``figures/...``), ``<details>`` for the long parameter tables; renders on a
  code-hosting site.
* :func:`render_html` -- ``index.html``: one self-contained file, the PNG figures
  embedded as base64 ``data:`` URIs, inline CSS, no scripts and no external resources;
  a navigation bar to the main sections (:func:`fitdf.report.outline.nav_links`) stays
  at the top of the window (CSS ``position: sticky``).

Re-render an existing report without refitting (a ``results.json`` of an earlier schema is
read as the current one, :mod:`fitdf.report.upgrade`)::

    import pathlib
    from fitdf.report.render import render_html
    from fitdf.report.upgrade import read_results
    out = pathlib.Path("reports")
    html = render_html(read_results(out), out)
"""

from __future__ import annotations

import base64
import html
import re
from pathlib import Path

from fitdf.report.document import fmt, slug
from fitdf.report.outline import build_document, nav_links
from fitdf.report.upgrade import upgrade

__all__ = ["build_document", "render_markdown", "render_html", "slug", "fmt"]


# ------------------------------------------------------------------ Markdown
def _md_cell(text: str) -> str:
    return str(text).replace("\n", " ").replace("|", "\\|")


def _md(blocks) -> list[str]:
    out = []
    for b in blocks:
        kind = b[0]
        if kind == "h":
            out += ["#" * b[1] + " " + b[2], ""]
        elif kind == "p":
            out += [b[1], ""]
        elif kind == "ul":
            out += [f"- {item}" for item in b[1]] + [""]
        elif kind == "table":
            out.append("| " + " | ".join(_md_cell(h) for h in b[1]) + " |")
            out.append("|" + "|".join("---" for _ in b[1]) + "|")
            out += ["| " + " | ".join(_md_cell(c) for c in row) + " |" for row in b[2]]
            out.append("")
        elif kind == "img":
            out += [f"![{b[2]}]({b[1]})", ""]
        elif kind == "details":
            out += (
                ["<details>", f"<summary>{html.escape(b[1])}</summary>", ""]
                + _md(b[2])
                + ["</details>", ""]
            )
        elif kind == "code":
            out += ["```", b[1], "```", ""]
    return out


def render_markdown(res: dict) -> str:
    """README.md text (figures linked relatively as ``figures/...``)."""
    return "\n".join(_md(build_document(res))).rstrip() + "\n"


# ------------------------------------------------------------------ HTML
_CSS = """
body{font-family:system-ui,-apple-system,'Segoe UI',Roboto,sans-serif;max-width:1300px;margin:0 auto;
padding:1.5em;color:#1f2328;line-height:1.45}
h1{font-size:1.7em;border-bottom:1px solid #d0d7de;padding-bottom:.3em}
h1,h2,h3{scroll-margin-top:3.2em}
nav.sections{position:sticky;top:0;z-index:10;background:#fff;border-bottom:1px solid #d0d7de;
padding:.45em 0;display:flex;flex-wrap:wrap;gap:.15em 1em;font-size:.9em}
nav.sections a{color:#0b57d0;text-decoration:none;white-space:nowrap}
nav.sections a:hover{text-decoration:underline}
h2{font-size:1.35em;border-bottom:1px solid #d0d7de;padding-bottom:.25em;margin-top:2em}
h3{font-size:1.1em;margin-top:1.4em}
table{border-collapse:collapse;margin:.6em 0;font-size:.85em;display:block;overflow-x:auto}
th,td{border:1px solid #d0d7de;padding:3px 7px;text-align:left;vertical-align:top}
th{background:#f6f8fa}tr:nth-child(even) td{background:#fbfbfc}
code{background:#f2f3f5;padding:.1em .3em;border-radius:4px;font-size:.92em}
img{max-width:100%;height:auto;border:1px solid #eee;margin:.4em 0}
details{margin:.5em 0}summary{cursor:pointer;color:#0b57d0}
pre{background:#f6f8fa;padding:.7em;overflow-x:auto;font-size:.8em}
"""


def _inline(text: str) -> str:
    t = html.escape(str(text), quote=False)
    t = re.sub(r"`([^`]+)`", r"<code>\1</code>", t)
    t = re.sub(r"\*\*(.+?)\*\*", r"<strong>\1</strong>", t)
    return re.sub(r"\[([^\]]+)\]\((#[^)\s]+)\)", r'<a href="\2">\1</a>', t)


def _data_uri(path: Path) -> str:
    return "data:image/png;base64," + base64.b64encode(path.read_bytes()).decode("ascii")


def _html(blocks, root: Path, ids: dict) -> list[str]:
    out = []
    for b in blocks:
        kind = b[0]
        if kind == "h":
            base = slug(b[2])
            n = ids.get(base, 0)
            ids[base] = n + 1
            hid = base if n == 0 else f"{base}-{n}"
            out.append(f'<h{b[1]} id="{hid}">{_inline(b[2])}</h{b[1]}>')
        elif kind == "p":
            out.append(f"<p>{_inline(b[1])}</p>")
        elif kind == "ul":
            out.append("<ul>" + "".join(f"<li>{_inline(i)}</li>" for i in b[1]) + "</ul>")
        elif kind == "table":
            head = "".join(f"<th>{_inline(h)}</th>" for h in b[1])
            body = "".join(
                "<tr>" + "".join(f"<td>{_inline(c)}</td>" for c in row) + "</tr>" for row in b[2]
            )
            out.append(f"<table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>")
        elif kind == "img":
            out.append(f'<img src="{_data_uri(root / b[1])}" alt="{html.escape(b[2])}">')
        elif kind == "details":
            out.append(
                f"<details><summary>{_inline(b[1])}</summary>"
                + "".join(_html(b[2], root, ids))
                + "</details>"
            )
        elif kind == "code":
            out.append(f"<pre>{html.escape(b[1])}</pre>")
    return out


def _nav(res: dict) -> str:
    links = "".join(
        f'<a href="#{html.escape(anchor)}">{html.escape(label)}</a>'
        for label, anchor in nav_links(res)
    )
    return f'<nav class="sections" aria-label="Report sections">{links}</nav>'


def render_html(res: dict, root) -> str:
    """index.html text: self-contained, figures read from ``root / 'figures/...'`` and embedded."""
    res = upgrade(res)
    body = "\n".join([_nav(res), *_html(build_document(res), Path(root), {})])
    return (
        '<!DOCTYPE html>\n<html lang="en">\n<head>\n<meta charset="utf-8">\n'
        '<meta name="viewport" content="width=device-width, initial-scale=1">\n'
        "<title>fitdf comparison report</title>\n"
        f"<style>{_CSS}</style>\n</head>\n<body>\n{body}\n</body>\n</html>\n"
    )
