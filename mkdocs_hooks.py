"""MkDocs hook: the command-line reference page is written from the Typer app itself, so it never drifts from the
commands: every command and sub-command with its help and options, as `--help` prints them."""

from __future__ import annotations

MARKER = "<!-- the commands, from the Typer app -->"


def _commands():
    import typer

    from sightplan.cli.main import app

    root = typer.main.get_command(app)

    def walk(cmd, path):
        yield path, cmd
        if hasattr(cmd, "list_commands"):  # a group
            ctx = cmd.context_class(cmd)
            for name in sorted(cmd.list_commands(ctx)):
                yield from walk(cmd.get_command(ctx, name), [*path, name])

    return root, list(walk(root, ["sightplan"]))


def _cell(text) -> str:
    return " ".join(str(text or "").split()).replace("|", "\\|")


def _param_row(param) -> str:
    names = ", ".join(f"`{n}`" for n in [*param.opts, *getattr(param, "secondary_opts", [])])
    default = param.default
    shown = "" if default is None or callable(default) or getattr(param, "is_flag", False) and default is False \
        else f"`{default}`"
    if isinstance(default, (list, tuple)):
        shown = "" if not default else f"`{', '.join(map(str, default))}`"
    return f"| {names} | {_cell(getattr(param, 'help', ''))} | {shown} |"


def reference() -> str:
    """Markdown for every command: its help, usage, arguments and options."""
    _, commands = _commands()
    parts = []
    for path, cmd in commands[1:]:
        name = " ".join(path)
        ctx = cmd.context_class(cmd, info_name=name)
        usage = " ".join(cmd.collect_usage_pieces(ctx))
        parts.append(f"## `{name}`\n\n{(cmd.help or '').strip()}\n\n```text\n{name} {usage}\n```\n")
        arguments = [p for p in cmd.params if p.param_type_name == "argument"]
        options = [p for p in cmd.params if p.param_type_name == "option" and not p.hidden]
        if arguments:
            parts.append("| argument | meaning | default |\n|---|---|---|\n"
                         + "\n".join(f"| `{a.name.upper()}` | {_cell(getattr(a, 'help', ''))} | "
                                      f"{'' if a.default is None else f'`{a.default}`'} |" for a in arguments) + "\n")
        if options:
            parts.append("| option | meaning | default |\n|---|---|---|\n"
                         + "\n".join(_param_row(o) for o in options) + "\n")
    return "\n".join(parts)


def on_page_markdown(markdown: str, page, **_kwargs) -> str:
    if MARKER in markdown:
        return markdown.replace(MARKER, reference())
    return markdown
