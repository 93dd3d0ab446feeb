"""The ``fitdf-cli`` directive: the command-line reference, rendered from the parser.

``.. fitdf-cli::`` calls :func:`fitdf.cli.build_parser` when the documentation is built and
writes, for the program and each subcommand, its description, usage, arguments (help text,
choices, default) and examples (the ``examples:`` epilog). Every text goes into the page as
plain text, never parsed as reStructuredText, so no help string can break the build, and
the page always matches ``fitdf COMMAND --help``.
"""

from __future__ import annotations

import argparse
import textwrap

from docutils import nodes
from sphinx.util.docutils import SphinxDirective


def _subcommands(parser: argparse.ArgumentParser):
    """``[(name, help, subparser)]`` of the parser's subcommands, in their order."""
    out = []
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            helps = {a.dest: a.help for a in action._choices_actions}
            for name, sub in action.choices.items():
                out.append((name, helps.get(name) or "", sub))
    return out


def _arguments(parser: argparse.ArgumentParser):
    """``[(term, help, default)]`` of the parser's own arguments (no subcommands); the
    choices are in the term, as in ``--help``."""
    formatter = parser._get_formatter()
    out = []
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction) or action.help == argparse.SUPPRESS:
            continue
        if action.option_strings:
            term = ", ".join(action.option_strings)
            if action.nargs != 0:
                term += " " + formatter._format_args(
                    action, formatter._get_default_metavar_for_optional(action)
                )
        else:
            term = formatter._format_args(
                action, formatter._get_default_metavar_for_positional(action)
            )
        text = formatter._expand_help(action) if action.help else ""
        default = None
        shown = action.default not in (None, False, argparse.SUPPRESS) and action.nargs != 0
        if shown and "default" not in text.lower():
            value = action.default
            default = " ".join(map(str, value)) if isinstance(value, list) else str(value)
        out.append((term, text, default))
    return out


def _examples(epilog: str | None):
    """The lines of an ``examples:`` epilog, dedented (None when there is none)."""
    if not epilog or not epilog.lstrip().lower().startswith("examples:"):
        return None
    body = epilog.lstrip().split("\n", 1)[1] if "\n" in epilog.strip() else ""
    return textwrap.dedent(body).strip("\n")


class FitdfCli(SphinxDirective):
    """Render ``fitdf.cli.build_parser()``: the program, then one section per subcommand."""

    has_content = False

    def _section(self, title: str, key: str) -> nodes.section:
        section = nodes.section(
            ids=[nodes.make_id(f"cli-{key}")], names=[nodes.fully_normalize_name(title)]
        )
        section += nodes.title(text=title)
        self.state.document.note_implicit_target(section, section)
        return section

    def _describe(self, parser: argparse.ArgumentParser, section: nodes.section, text: str) -> None:
        if text:
            section += nodes.paragraph(text=text)
        usage = parser.format_usage().strip()
        usage = usage[len("usage: ") :] if usage.startswith("usage: ") else usage
        section += nodes.literal_block(text=usage, language="none")
        items = []
        for term, help_text, default in _arguments(parser):
            description = nodes.definition()
            if help_text:
                description += nodes.paragraph(text=help_text)
            if default is not None:
                description += nodes.paragraph(text=f"Default: {default}.")
            items.append(
                nodes.definition_list_item(
                    "", nodes.term("", "", nodes.literal(text=term)), description
                )
            )
        if items:
            section += nodes.rubric(text="Arguments")
            section += nodes.definition_list("", *items)
        examples = _examples(parser.epilog)
        if examples:
            section += nodes.rubric(text="Examples")
            section += nodes.literal_block(text=examples, language="none")

    def run(self):
        from fitdf.cli import build_parser

        parser = build_parser()
        top = nodes.container()
        self._describe(parser, top, parser.description or "")
        result = [*top.children]
        for name, help_text, sub in _subcommands(parser):
            section = self._section(f"fitdf {name}", name)
            self._describe(sub, section, sub.description or help_text)
            result.append(section)
        return result


def setup(app):
    app.add_directive("fitdf-cli", FitdfCli)
    return {"version": "1", "parallel_read_safe": True, "parallel_write_safe": True}
