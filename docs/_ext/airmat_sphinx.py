"""Local Sphinx extension of the airmat docs.

``airmat-cli`` (directive)
    The command-line reference, generated at build time from the argparse parser
    (``airmat.cli.build_parser()``): the command's usage, description and global
    options, one section per subcommand (usage, description, options by group),
    the epilog, and the exit-code table of ``airmat.cli._exit``'s docstring.
    In a MyST page::

        ```{airmat-cli}
        ```

Generated API sections (``% airmat-modules: PACKAGE``, ``% airmat-core: PACKAGE``, ``% airmat-facade:``)
    A page's MyST comment line ``% airmat-modules: airmat.calib`` becomes, when
    the page is read, the package's docstring and one ``###`` heading with an
    ``automodule`` per public module (walked with pkgutil: a new module is
    documented without editing the page; names a module re-exports through its
    ``__all__`` are documented where they are defined). ``% airmat-facade:``
    becomes one entry per name of ``airmat._FACADE``; ``% airmat-core: airmat``, one
    section per module directly in ``airmat`` (its subpackages have their own lines).
"""

from __future__ import annotations

import argparse
import importlib
import inspect
import pkgutil
import re

from docutils import nodes
from docutils.parsers.rst import directives
from sphinx.util import logging
from sphinx.util.docutils import SphinxDirective

logger = logging.getLogger(__name__)

WIDTH = 88  # usage lines wrap here, whatever the terminal of the build


def _formatter(parser: argparse.ArgumentParser) -> argparse.HelpFormatter:
    try:
        return parser.formatter_class(prog=parser.prog, width=WIDTH)
    except TypeError:  # a formatter class without ``width``
        return parser._get_formatter()


def _usage(parser: argparse.ArgumentParser) -> str:
    formatter = _formatter(parser)
    formatter.add_usage(parser.usage, parser._actions, parser._mutually_exclusive_groups)
    return formatter.format_help().strip()


def _text_blocks(text: str, raw: bool) -> list[nodes.Node]:
    """Paragraphs of a description or epilog; with a raw formatter, indented blocks stay preformatted."""
    out: list[nodes.Node] = []
    for block in re.split(r"\n\s*\n", inspect.cleandoc(text)):
        lines = block.splitlines()
        if not lines:
            continue
        if raw and any(line[:1].isspace() for line in lines):
            out.append(nodes.literal_block(block, block))
        elif raw and lines[0].endswith(":") and len(lines) > 1 and any(line[:1].isspace() for line in lines[1:]):
            out.append(nodes.literal_block(block, block))
        else:
            out.append(nodes.paragraph("", " ".join(line.strip() for line in lines)))
    return out


def _is_raw(parser: argparse.ArgumentParser) -> bool:
    return issubclass(parser.formatter_class, argparse.RawDescriptionHelpFormatter)


def _section(document, title: str, ids: str) -> nodes.section:
    section = nodes.section(ids=[nodes.make_id(ids)], names=[nodes.fully_normalize_name(title)])
    section["support_smartquotes"] = False  # option names and quotes exactly as --help prints them
    section += nodes.title(title, title)
    document.note_implicit_target(section, section)
    return section


def _subparsers(parser: argparse.ArgumentParser):
    return [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]


def _options(parser: argparse.ArgumentParser, command_ids: dict[str, str]) -> list[nodes.Node]:
    """One rubric and definition list per argument group (positional arguments, options, ...)."""
    formatter = _formatter(parser)
    out: list[nodes.Node] = []
    for group in parser._action_groups:
        actions = [a for a in group._group_actions if a.help is not argparse.SUPPRESS]
        if not actions:
            continue
        out.append(nodes.rubric(group.title or "", group.title or ""))
        if group.description:
            out.append(nodes.paragraph("", group.description))
        items = nodes.definition_list()
        for action in actions:
            if isinstance(action, argparse._SubParsersAction):
                for choice in action._choices_actions:
                    term = nodes.term()
                    ref = nodes.reference("", "", internal=True, refid=command_ids.get(choice.dest, ""))
                    ref += nodes.literal(choice.dest, choice.dest)
                    term += ref
                    items += nodes.definition_list_item("", term,
                                                        nodes.definition("", nodes.paragraph("", choice.help or "")))
                continue
            invocation = formatter._format_action_invocation(action)
            term = nodes.term("", "", nodes.literal(invocation, invocation))
            help_text = formatter._expand_help(action) if action.help else ""
            if action.required and action.option_strings:
                help_text = f"{help_text} (required)".strip()
            if action.choices is not None and not isinstance(action, argparse._SubParsersAction) \
                    and "{" not in invocation:
                help_text += f" Choices: {', '.join(map(str, action.choices))}."
            items += nodes.definition_list_item("", term, nodes.definition("", nodes.paragraph("", help_text)))
        out.append(items)
    return out


def _exit_table(module_name: str) -> list[nodes.Node]:
    """The docstring of the exit-code module, parsed as reStructuredText (its table)."""
    from docutils.core import publish_doctree

    doc = inspect.getdoc(importlib.import_module(module_name)) or ""
    tree = publish_doctree(doc, settings_overrides={"report_level": 5, "halt_level": 5})
    return [node.deepcopy() for node in tree.children if not isinstance(node, nodes.system_message)]



def _command_body(parser, command_ids) -> list:
    """A command's usage, description, options and epilog, as docutils nodes."""
    body = [nodes.literal_block("", _usage(parser))]
    if parser.description:
        body += list(_text_blocks(parser.description, _is_raw(parser)))
    body += list(_options(parser, command_ids))
    if parser.epilog:
        body += list(_text_blocks(parser.epilog, _is_raw(parser)))
    return body

class AirmatCli(SphinxDirective):
    """Emit the CLI reference of ``MODULE.FUNC()`` (an ``argparse.ArgumentParser``)."""

    has_content = False
    option_spec = {
        "module": directives.unchanged,
        "func": directives.unchanged,
        "exit-codes": directives.unchanged,
    }

    def run(self) -> list[nodes.Node]:
        module = self.options.get("module", "airmat.cli")
        func = self.options.get("func", "build_parser")
        parser = getattr(importlib.import_module(module), func)()
        document = self.state.document
        prog = parser.prog

        subs = _subparsers(parser)
        commands, seen = [], set()
        for name, sub in (subs[0].choices.items() if subs else ()):   # an alias shares its command's parser
            if id(sub) not in seen:
                seen.add(id(sub))
                commands.append((name, sub))
        helps = {c.dest: c.help for c in subs[0]._choices_actions} if subs else {}
        command_ids = {name: nodes.make_id(f"cli-{prog}-{name}") for name, _ in commands}

        out: list[nodes.Node] = []
        top = _section(document, prog, f"cli-{prog}")
        top += _command_body(parser, command_ids)
        out.append(top)

        for name, sub in commands:
            section = _section(document, f"{prog} {name}", f"cli-{prog}-{name}")
            if helps.get(name):
                section += nodes.paragraph("", "", nodes.emphasis(helps[name], helps[name]))
            section += _command_body(sub, command_ids)
            out.append(section)

        exit_module = self.options.get("exit-codes", f"{module}._exit")
        try:
            table = _exit_table(exit_module)
        except ImportError:
            table = []
        if table:
            section = _section(document, "Exit codes", f"cli-{prog}-exit-codes")
            section += table
            out.append(section)
        return out


def _public_modules(package: str, core: bool = False) -> list[str]:
    """``package`` and its modules, depth first in name order, less private ``_name`` ones and ``__main__``;
    ``core``: only the modules directly in ``package`` that are not packages (and not ``package`` itself)."""
    pkg = importlib.import_module(package)
    if core:
        return [f"{package}.{info.name}" for info in pkgutil.iter_modules(pkg.__path__)
                if not info.ispkg and not info.name.startswith("_")]
    names = [package]
    for info in pkgutil.walk_packages(pkg.__path__, f"{package}."):
        if not any(part.startswith("_") for part in info.name[len(package) + 1:].split(".")):
            names.append(info.name)
    return names


def _reexported(module_name: str) -> list[str]:
    """Names in a module's ``__all__`` whose class or function is defined elsewhere (documented there)."""
    module = importlib.import_module(module_name)
    out = []
    for name in getattr(module, "__all__", None) or []:
        obj = getattr(module, name, None)
        if (inspect.isclass(obj) or inspect.isroutine(obj)) and getattr(obj, "__module__", module_name) != module_name:
            out.append(name)
    return out


def _automodule(name: str, members: bool) -> list[str]:
    lines = ["```{eval-rst}", f".. automodule:: {name}"]
    if not members:
        lines.append("   :no-members:")
    else:
        skip = _reexported(name)
        if skip:
            lines.append(f"   :exclude-members: {', '.join(skip)}")
    return lines + ["```", ""]


def _modules_markdown(package: str, level: int, core: bool = False) -> str:
    """The sections of a package's modules: the package's own entry, then one heading and automodule each
    (``core``: only the modules directly in the package, no entry of its own)."""
    lines = [] if core else _automodule(package, members=True)
    for name in _public_modules(package, core)[0 if core else 1:]:
        lines += [f"{'#' * level} `{name}`", ""]
        lines += _automodule(name, members=True)
    return "\n".join(lines)


def _facade_markdown() -> str:
    """The names of ``airmat._FACADE``, each as the object it loads, pointing to its full entry."""
    import airmat

    lines = ["```{eval-rst}"]
    for public, target in airmat._FACADE.items():
        module, _, attr = target.partition(":")
        obj = getattr(importlib.import_module(module), attr)
        kind = "autoclass" if inspect.isclass(obj) else "autofunction"
        lines += [f".. {kind}:: airmat.{public}", "   :no-index:"]
        if kind == "autoclass":
            lines.append("   :no-members:")
        lines += ["", f"   Full entry: :py:obj:`{module}.{attr}`.", ""]
    return "\n".join(lines + ["```", ""])


_MARKER = re.compile(r"^% airmat-(modules|core|facade):[ \t]*(\S*)[ \t]*$", re.MULTILINE)


def _expand(match: re.Match) -> str:
    kind, package = match.group(1), match.group(2)
    if kind == "facade":
        return _facade_markdown()
    return _modules_markdown(package, level=3, core=kind == "core")


def _source_read(app, docname: str, source: list[str]) -> None:
    """Expand the ``% airmat-modules:``, ``% airmat-core:`` and ``% airmat-facade:`` lines (MyST comments) of a page."""
    markers = _MARKER.findall(source[0])
    if markers:
        source[0] = _MARKER.sub(_expand, source[0])
        if not hasattr(app.env, "airmat_generated"):
            app.env.airmat_generated = {}
        app.env.airmat_generated[docname] = (markers, _listing(markers))


def _listing(markers) -> list[str]:
    import airmat

    return [f"facade {sorted(airmat._FACADE.items())}" if kind == "facade" else f"{kind} {_public_modules(package, kind == 'core')}"
            for kind, package in markers]


def _outdated(app, env, added, changed, removed) -> list[str]:
    """Pages whose generated sections changed (a module or a facade name added or removed) are read again."""
    generated = getattr(env, "airmat_generated", {})
    return [doc for doc, (markers, listing) in generated.items() if doc not in removed and _listing(markers) != listing]


def _merge(app, env, docnames, other) -> None:
    if not hasattr(env, "airmat_generated"):
        env.airmat_generated = {}
    theirs = getattr(other, "airmat_generated", {})
    env.airmat_generated.update({doc: theirs[doc] for doc in docnames if doc in theirs})


def _purge(app, env, docname: str) -> None:
    getattr(env, "airmat_generated", {}).pop(docname, None)


# text in which a bar is markup, not an absolute value: inline literals, roles, interpreted text
_PROTECTED = re.compile(r"``.+?``|:[\w:+.-]+:`[^`]*`|`[^`]*`_{0,2}")
_BLOCK_START = re.compile(r"(::\s*$)|(^\s*\.\. )")


def _escape_bars(app, what, name, obj, options, lines: list[str]) -> None:
    """Docstrings write absolute values and norms as ``|κ|``, ``|b - a|``, ``||κ1| − |κ2||``:
    reStructuredText reads ``|κ|`` as a substitution reference (an undefined one: an error).
    Escape every bar of running text; inline literals, roles, literal blocks, directives,
    doctest blocks and grid-table or line-block lines (starting ``| ``, ``+-`` or ``+=``) stay as written.
    airmat's docstrings define no substitutions."""
    block_indent = None      # indent of the line that opened a literal block or directive
    doctest = False
    for i, line in enumerate(lines):
        stripped = line.lstrip()
        indent = len(line) - len(stripped)
        if not stripped:
            doctest = False
            continue
        if block_indent is not None:
            if indent > block_indent:
                continue
            block_indent = None
        if doctest or stripped.startswith(">>>"):
            doctest = True
            continue
        if _BLOCK_START.search(line):
            block_indent = indent
        if "|" not in line or stripped.startswith(("| ", "+-", "+=")) or stripped == "|":
            continue
        parts, last = [], 0
        for m in _PROTECTED.finditer(line):
            parts.append(_escape(line[last:m.start()]))
            parts.append(m.group(0))
            last = m.end()
        parts.append(_escape(line[last:]))
        lines[i] = "".join(parts)


def _escape(text: str) -> str:
    return re.sub(r"(?<!\\)\|", r"\\|", text)


def setup(app):
    app.add_directive("airmat-cli", AirmatCli)
    app.connect("source-read", _source_read)
    app.connect("env-get-outdated", _outdated)
    app.connect("env-purge-doc", _purge)
    app.connect("env-merge-info", _merge)
    app.connect("autodoc-process-docstring", _escape_bars, priority=600)
    return {"version": "1", "parallel_read_safe": True, "parallel_write_safe": True}
