"""The ``chameleons`` command. Each sub-command lives in its own module, imported only when
that command runs: ``chameleons --help`` and every command's start-up stay cheap (the web
application, SciPy and pandas are loaded by the commands that use them, not by all)."""

from __future__ import annotations

import importlib

import click

from chameleons import __version__

# name -> (module, attribute, the one-line help shown by ``chameleons --help``). A test checks
# that each line equals the command's own short help, so the table cannot drift from it.
COMMANDS: dict[str, tuple[str, str, str]] = {
    "analyze": ("analyze_command", "analyze_command",
                "Descriptives, Friedman tests (Bonferroni, Kendall's W), post-hoc tests, "
                "effect sizes with bootstrap intervals and the regression models."),
    "booth-check": ("booth_check_command", "booth_check",
                    "Check a booth before a participant: face stream, head turn and nod, robot, "
                    "copy delay, test prompt and disk space."),
    "db": ("db_commands", "db", "Database schema: apply and inspect migrations."),
    "demo": ("demo_command", "demo",
             "Start the whole system on its embedded default: the server on SQLite with the "
             "demo study and plan, a local worker driving the virtual robot, and a simulated "
             "face (or, with --webcam, the webcam capture page's link)."),
    "export": ("export_command", "export",
               "Export participants, interactions, suggestions, questionnaire, scores and "
               "events."),
    "face-track": ("face_track_command", "face_track",
                   "Track the face in a video (MP4, WebM, MOV, MJPEG AVI) and write it as a "
                   "Live Link Face take: ARKit's 52 values and head and eye rotations in "
                   "radians, the video's time as the timecode, frames without a face left "
                   "out."),
    "import-eaf": ("eaf_command", "import_eaf",
                   "Read coders' ELAN annotations of exported sessions back, for inter-rater "
                   "reliability (a coder's earlier import of the same session is replaced)."),
    "import-xdf": ("xdf_command", "import_xdf_command",
                   "Attach the other instruments' streams of an XDF recording (EMG, eye "
                   "tracking, physiology, other tools' markers) to a session, aligned through "
                   "this system's LSL markers."),
    "keys": ("keys_command", "keys",
             "CURVE keys that authenticate and encrypt the link between server and workers."),
    "plan": ("plan_command", "plan_command",
             "Print the counterbalancing plan for N participants and how balanced it is."),
    "power": ("power_command", "power_command",
              "Power of the Friedman tests and the models at N = 12, 24, ... and the N needed, "
              "by simulating the planned design under assumed effects."),
    "prereg": ("prereg_command", "prereg_command",
               "Hypotheses, design, planned N with its power, variables and the analysis plan, "
               "as one Markdown document to upload to OSF before data collection."),
    "prompts": ("prompts_command", "prompts",
                "Work with the prompt catalogue (prompts/<actor>/)."),
    "rehearse": ("rehearse_command", "rehearse",
                 "Run whole sessions with a scripted wizard and participant, marked as "
                 "rehearsals."),
    "reliability": ("eaf_command", "reliability",
                    "Inter-rater reliability of the coders' ELAN annotations per tier: Cohen's "
                    "kappa per pair of coders, Fleiss' kappa and Krippendorff's alpha."),
    "serve": ("serve_command", "serve",
              "Run the web server (wizard console, phone pages, PI dashboard, API)."),
    "simulate-face": ("simulate_face_command", "simulate_face",
                      "Send a plausible synthetic face (blinks, head sway, smiles, talking) or a "
                      "Live Link Face take to a worker, as a phone would."),
    "synchrony": ("synchrony_command", "synchrony",
                  "Compute the synchrony of the recorded faces per interaction: the robot "
                  "following the participant, the participant following the robot, and their "
                  "surrogate baseline."),
    # issue 31: start a lab's own study from a shipped template
    "study": ("study_command", "study",
              "Start a lab's own study from a shipped template (chameleons study templates)."),
    "user": ("user_commands", "user", "Staff accounts (PI and wizards)."),
    "webcam-calibrate": ("webcam_calibrate_command", "webcam_calibrate",
                         "Teach a booth's webcam with its iPhone: fit, per ARKit channel, the "
                         "map from the webcam's landmark features to the iPhone's values and "
                         "write it for `chameleons worker --webcam-map`."),
    "worker": ("worker_command", "worker",
               "Run the realtime worker of one booth (capture -> behaviour -> renderer -> "
               "robot)."),
}  # fmt: skip


class LazyGroup(click.Group):
    """A group whose sub-commands are imported on first use (click's documented pattern)."""

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted(COMMANDS)

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        if cmd_name not in COMMANDS:
            return None
        module_name, attribute, _ = COMMANDS[cmd_name]
        module = importlib.import_module(f"chameleons.cli.{module_name}")
        command = getattr(module, attribute)
        assert isinstance(command, click.Command)
        return command

    def format_commands(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        # The listing uses the table's help lines, so ``--help`` imports no command module.
        limit = formatter.width - 6 - max(len(name) for name in COMMANDS)
        rows = [(name, _shorten(COMMANDS[name][2], limit)) for name in sorted(COMMANDS)]
        with formatter.section("Commands"):
            formatter.write_dl(rows)


def _shorten(text: str, limit: int) -> str:
    """The first sentence, cut at ``limit`` characters as click's own short help is."""
    return click.Command("x", help=text).get_short_help_str(limit=limit)


@click.group(cls=LazyGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="chameleons")
def cli() -> None:
    """Mechanical Chameleons: run Wizard-of-Oz studies of robot facial mimicry."""


def main() -> None:
    cli()
