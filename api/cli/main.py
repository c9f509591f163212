"""The ``rcb`` app: one-line usage errors, and every command registered (each in its module).

Exit codes: 0 success, 2 bad input (the message names the field and value), 3 infeasible
(the message names the conflicting limits), 4 solver failure.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from typing import Any

import typer
from typer.core import TyperGroup

try:  # recent typer vendors click as typer._click; its exceptions are not click's
    from typer._click import exceptions as click_errors
except ImportError:  # pragma: no cover - typer that uses click itself
    from click import exceptions as click_errors  # type: ignore[no-redef]

from api.cli import plans as cli_plans
from api.cli import replan as cli_replan
from api.cli import review as cli_review
from api.cli.admin import db_app, keys_app, serve
from api.cli.audit import audit
from api.cli.cam import cam_app
from api.cli.certify import certify
from api.cli.collect import collect
from api.cli.common import say_error
from api.cli.demo import demo
from api.cli.examples import examples_app
from api.cli.export import export
from api.cli.fit import fit
from api.cli.fleet import fleet_app
from api.cli.gcode import gcode
from api.cli.helptext import escape_tree
from api.cli.html_report import html_report
from api.cli.lazy import lazy_group
from api.cli.models import models_app
from api.cli.optimize import optimize, predict
from api.cli.tools import tools_app
from api.cli.usage_errors import said as usage_said
from api.cli.usage_words import said
from api.cli.virtual import virtual_app
from models.errors import InputError


class _OneLineErrors(TyperGroup):
    """Report usage errors (a value that is not a number, a missing argument) in one line."""

    def main(
        self,
        args: Sequence[str] | None = None,
        prog_name: str | None = None,
        complete_var: str | None = None,
        standalone_mode: bool = True,
        windows_expand_args: bool = True,
        **extra: Any,
    ) -> Any:
        """Run the command; on a usage error print ``rcb: error: ...`` and exit 2."""
        escape_tree(self)  # "[mm]" in a help text is a unit, not Rich markup
        if not standalone_mode:
            return super().main(args, prog_name, complete_var, False, windows_expand_args, **extra)
        try:
            code = super().main(args, prog_name, complete_var, False, windows_expand_args, **extra)
        except click_errors.NoArgsIsHelpError as err:
            # the error's constructor rendered the help already (typer's rich help prints
            # itself and returns ""); plain click returns it as the message
            text = err.format_message()
            if text.strip():
                typer.echo(text)
            sys.exit(err.exit_code)
        except click_errors.ClickException as err:
            # typer's own coercion and click's usage errors, in rcb's words
            message = said(err) or usage_said(err) or " ".join(err.format_message().split())
            say_error(f"rcb: error: {message}")
            sys.exit(err.exit_code)
        except InputError as err:  # an option's own check as it is read (--strategy)
            typer.echo(f"rcb: error: {err}", err=True)
            sys.exit(2)
        except typer.Abort:
            typer.echo("rcb: aborted", err=True)
            sys.exit(1)
        sys.exit(code if isinstance(code, int) else 0)


app = typer.Typer(
    cls=_OneLineErrors,
    name="rcb",
    help="Robust optimisation and Recursive Constraint Bounding of cutting parameters.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)

# The order of registration is the order of ``rcb --help``.
app.command()(predict)  # rcb predict: api/cli/optimize.py
app.command()(optimize)  # rcb optimize: api/cli/optimize.py
app.command()(demo)  # rcb demo: api/cli/demo.py
app.command()(certify)  # rcb certify: api/cli/certify.py
app.command()(fit)  # rcb fit: api/cli/fit.py
app.command()(gcode)  # rcb gcode: api/cli/gcode.py
app.command("report")(html_report)  # rcb report: api/cli/html_report.py
#: ``rcb plans``: alone (or ``list``) it lists; ``create`` and ``show``: api/cli/plans.py
plans_app = typer.Typer(invoke_without_command=True, no_args_is_help=False)
plans_app.callback()(cli_review.plans)
plans_app.command("list")(cli_review.plans)
plans_app.command("create")(cli_plans.create)
plans_app.command("show")(cli_plans.show)
app.add_typer(plans_app, name="plans")  # api/cli/review.py, api/cli/plans.py
app.add_typer(models_app, name="models")  # rcb models export|import: api/cli/models.py
app.add_typer(fleet_app, name="fleet")  # rcb fleet exclude|include: api/cli/fleet.py
app.add_typer(tools_app, name="tools")  # rcb tools list|show|add: api/cli/tools.py
for _review in (
    cli_review.history,
    cli_review.parts,
    export,
    cli_replan.replan,
):
    app.command()(_review)  # api/cli/review.py, export.py, replan.py
app.add_typer(db_app, name="db")  # rcb db upgrade: api/cli/admin.py
app.add_typer(keys_app, name="keys")  # rcb keys create|revoke: api/cli/admin.py
app.command()(audit)  # rcb audit: api/cli/audit.py
#: ``rcb milling``: its commands' modules load NumPy for their options' defaults and choices, so
#: they are imported only when ``rcb milling ...`` runs (api/cli/lazy.py).
milling_app = typer.Typer(
    cls=lazy_group(
        {
            "domain": "api.cli.domain:domain",
            "control": "api.cli.milling_control:control",
            "setup": "api.cli.milling:setup",
        }
    ),
    help="Milling: constant-load setup (Tai et al.), the (feed, speed) domain (Borangiu et al.), "
    "inner feed-control loops on a paper's case.",
    no_args_is_help=True,
)
app.add_typer(milling_app, name="milling")  # rcb milling domain|control|setup
app.add_typer(cam_app, name="cam")  # rcb cam depthmap: api/cli/cam.py
app.add_typer(examples_app, name="examples")  # rcb examples [copy]: api/cli/examples.py
app.command()(serve)  # rcb serve: api/cli/admin.py
app.command()(collect)  # rcb collect: api/cli/collect.py
app.add_typer(virtual_app, name="virtual")  # rcb virtual serve: api/cli/virtual.py
