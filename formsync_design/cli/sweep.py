"""``formsync sweep``: topology sweeps and Monte-Carlo campaigns on Dask."""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path
from typing import Any

from formsync_design.cli.options import (
    EXIT_INTERRUPTED,
    EXIT_OK,
    add_format_option,
    add_trust_option,
    emit_json,
    whole_number,
)
from formsync_design.errors import InputError
from formsync_design.progress import Progress

__all__ = ["add_parser", "run"]

_DESC = """\
Run a campaign of one design over many communication graphs x gain boxes and
collect, per graph: spectral facts (degrees, lambda_2 and lambda_max of the
Laplacian), the certification status of reference gains (liang2016, the
default: the paper's K_o = 1.6, K_q = 0.4, beta = 0.3), the certified-region
summary of each box (volume fractions certified / refuted / undecided at
resolution R), recommended gains with the largest certified box around them,
and - with --mc-runs or a [montecarlo] table - Monte-Carlo convergence
statistics on the nonlinear formation.

Design: --design NAME|FILE (or `design = "NAME|FILE"` in the [campaign] table,
a file relative to the campaign file; --spec and `spec` are the old names).
The box and the reference are over the design's controller gains, given by
name: --gain NAME=LO:HI (repeat; liang2016 also --ko/--kq/--beta), --ref
NAME=X,NAME=X (or the values in the design's gain order), [[box]] and
[reference] tables keyed by the gains.  A gain not given takes its declared
range (liang2016: the standard box 0.05:5 x 0.05:5 x 0.01:1); the reference
defaults to the design's shipped case.  Multipliers of the Lyapunov candidate
(pd_consensus's eps) are never given: every certificate searches them over
their declared ranges, and the values that certify are reported as evidence
(columns ref_cert_eps, rec_cert_eps).  The columns of results.csv are named
after the design's gains (box_k_p_lo, ref_k_d, rec_k_p, ...).  The design's
content is part of the campaign sha256, so a folder of another design is
refused.

An agent design (FORM = "agent": ma_so3, lv2012, ...) is swept as formsync
certify, region and design run it: its conditions(c) families on each graph,
a column `theorem` flagging a graph outside its theorem (computed, not
refused), a box of at most three free axes counting the searched multipliers
(ma_so3: give P1, P2 a single value), --design-betas K the gain design's grid
per axis; --mc-runs N runs the agent Monte-Carlo (formsync montecarlo --design
NAME) on its shipped case or --mc-case (spacecraft cycled over the graph's, the
case's simulation options unless --mc-tf); a design with a leader has none.

Graph sets (repeat --graphs):
  ring:N | path:N | star:N | complete:N     N a number or a range A..B (ring:4..12)
  circulant:N:a,b                          N may be a range
  atlas:N | atlas:A..B | atlas:N<=7        all connected graphs of the networkx atlas
  random:N:P:SEEDS                         seeded G(N,P); SEEDS a seed or a range 0..19
                                           (disconnected draws are skipped and listed)
  dir:FOLDER | FOLDER                      every *.txt/*.edges/*.el/*.edgelist/*.csv file
  FILE                                     one edge-list or adjacency-CSV file

Results (DIR): manifest.json (campaign definition + sha256), results.csv (tidy
table, one row per graph x box, schema in summary.md), summary.md and figures
(certified fraction vs lambda_max(L) and vs maximum degree; convergence time vs
lambda_2 with Monte-Carlo).  Rows are appended to DIR/journal.jsonl with fsync
as tasks finish: after a kill, the same command with --resume computes only the
missing tasks.  A DIR written by a different campaign is refused (exit 2,
nothing overwritten).  With `compare = "OTHER_DIR"` in the [campaign] table,
summary.md compares the reference statuses with another sweep's results on the
same graphs (matched up to relabelling; its results are part of the sha256).

Execution: a local dask.distributed cluster of --workers processes (default 2,
one thread each); --scheduler ADDRESS uses an existing cluster (its workers
need formsync-design installed); --workers 0 runs serially in this process.

Limits (refused up front, exit 2): at most 2000 spacecraft per graph, 100000
tasks (graphs x boxes) and 10^7 Monte-Carlo simulations per campaign.

Ctrl-C stops the sweep within a second or two (exit 130); finished rows stay in
DIR/journal.jsonl and --resume completes the campaign.

Exit status: 0 campaign complete; 2 bad input (unknown family, empty set, a
gain the design does not declare, a box missing a gain, a malformed
--scheduler address, a campaign too large, a foreign results folder, a task
that rejected its input); 3 a failure that is not your input (scheduler
unreachable or without workers, a worker died, a task crashed: finished rows
are kept, rerun with --resume); 130 interrupted.

examples:
  formsync sweep --graphs atlas:6 --out out/atlas6
  formsync sweep --graphs ring:4..12 --graphs star:4..12 --ko 0.05:5 --kq 0.05:5 \\
      --beta 0.01:1 --resolution 16 --out out/families
  formsync sweep --graphs random:8:0.4:0..19 --mc-runs 200 --mc-gains recommended --out out/rnd
  formsync sweep --campaign verification/sweep_atlas6.toml --out reports/sweep-atlas6 --overwrite
  formsync sweep --campaign big.toml --out out/big --scheduler tcp://10.0.0.5:8786 --resume
  formsync sweep --design pd_consensus --graphs atlas:2..5 --gain k_p=0.1:2 --gain k_d=0.5:3 \
      --ref k_p=0.4,k_d=1.6 --out out/pd      # the PD baseline: its gains, eps searched
  formsync sweep --design ma_so3 --graphs ring:4..6 --gain K1=0.5:2 --gain K2=0.05:0.5 \
      --gain P1=0.03 --gain P2=0.03 --out out/ma_so3   # an agent design, mu searched
"""

_DEF_FLAGS = ("graphs", "gain", "ko", "kq", "beta", "ref", "resolution", "design_betas", "conditions",
              "margin", "mc_runs", "mc_seed", "mc_gains", "mc_tf", "mc_case", "name")


def add_parser(sub: Any) -> None:
    p = sub.add_parser(
        "sweep",
        help="campaign over graph sets x gain boxes (certification, regions, design, "
        "Monte-Carlo) on Dask",
        description=_DESC,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    d = p.add_argument_group("campaign definition (a --campaign FILE, or these flags)")
    d.add_argument("--campaign", metavar="FILE", default=None,
                   help="campaign TOML ([campaign] graphs and design, [reference], [[box]], "
                   "[region], [design], [montecarlo]; see formsync_design/sweep/campaign.py)")
    d.add_argument("--graphs", action="append", metavar="SET", default=None,
                   help="graph set (repeatable), e.g. ring:4..12, atlas:6, random:8:0.4:0..9")
    d.add_argument("--name", default=None, help="campaign name (default 'sweep')")
    d.add_argument("--design", "--spec", dest="spec", default=None, metavar="NAME|FILE",
                   help="the design: a shipped design's name (liang2016, pd_consensus, the agent "
                   "designs ma_so3, lv2012, ...) or a design "
                   ".py file (default liang2016; with --campaign, when the file names none)")
    d.add_argument("--gain", action="append", default=None, metavar="NAME=LO:HI",
                   help="range of a controller gain of the design in the box (repeat); default its "
                   "declared range (liang2016: K_o 0.05:5, K_q 0.05:5, beta 0.01:1)")
    d.add_argument("--ko", default=None, metavar="LO:HI", help="liang2016: K_o range (= --gain K_o=LO:HI)")
    d.add_argument("--kq", default=None, metavar="LO:HI", help="liang2016: K_q range (= --gain K_q=LO:HI)")
    d.add_argument("--beta", default=None, metavar="LO:HI",
                   help="liang2016: beta range (= --gain beta=LO:HI)")
    d.add_argument("--ref", default=None, metavar="NAME=X,...",
                   help="reference gains certified for every graph: NAME=X pairs or the values in "
                   "the design's gain order (default: liang2016 1.6,0.4,0.3; another design its "
                   "shipped case's)")
    d.add_argument("--resolution", type=whole_number, default=None, metavar="R",
                   help="region map: finest box = 1/R of each range (default 8)")
    d.add_argument("--design-betas", type=whole_number, default=None, metavar="K",
                   help="values of the third gain swept by the gain design (beta; pd_consensus: "
                   "its multiplier eps), default 5")
    d.add_argument("--conditions", default=None, choices=("derived", "paper"),
                   help="Lyapunov conditions: derived (default) or the paper's printed ones")
    d.add_argument("--margin", default=None, metavar="EPS", help="require lambda_min > EPS (default 0)")
    d.add_argument("--mc-runs", type=whole_number, default=None, metavar="N",
                   help="Monte-Carlo runs per graph (default: no Monte-Carlo)")
    d.add_argument("--mc-seed", type=whole_number, default=None, metavar="S", help="Monte-Carlo master seed (default 0)")
    d.add_argument("--mc-gains", default=None, choices=("reference", "recommended"),
                   help="gains simulated (default reference)")
    d.add_argument("--mc-tf", default=None, metavar="S", help="Monte-Carlo horizon in s (default 200; an agent design: "
                   "its case's)")
    d.add_argument("--mc-case", default=None, metavar="FILE",
                   help="case TOML for inertias/orbit/disturbance/K_v (default the paper's; "
                   "inertias are cycled for larger formations); an agent design: an agent "
                   "case (default its shipped one), its spacecraft cycled")
    x = p.add_argument_group("execution")
    x.add_argument("--out", default=None, metavar="DIR",
                   help="results folder (default out/sweep-<design> under the working directory)")
    x.add_argument("--resume", action="store_true",
                   help="finish an interrupted run of the same campaign in DIR (finished tasks kept)")
    x.add_argument("--overwrite", action="store_true",
                   help="recompute DIR from scratch (only a folder of the same campaign)")
    x.add_argument("--workers", type=whole_number, default=2, metavar="N",
                   help="local Dask worker processes (default 2; 0 = serial, no Dask)")
    x.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="existing Dask scheduler, e.g. tcp://10.0.0.5:8786")
    x.add_argument("--timeout", default="10", metavar="S",
                   help="seconds to wait for the scheduler and its workers (default 10)")
    x.add_argument("--no-progress", action="store_true", help="no progress line on stderr")
    add_format_option(p)
    add_trust_option(p)
    p.set_defaults(func=run)


def _box_from_flags(args: argparse.Namespace, sp: Any, schema: Any) -> dict[str, Any]:
    """The box of ``--gain`` (and liang2016's ``--ko/--kq/--beta``) over the design's
    controller gains, a gain not given taking its default (:func:`~.sweep.designs.default_box`)."""
    from formsync_design.cli.options import parse_gain_assignments
    from formsync_design.gains import parse_gain_range
    from formsync_design.sweep.designs import DEFAULT_BOX, gain_key_error

    given = parse_gain_assignments(args.gain)
    err = gain_key_error(sp, schema, "--gain", list(given))
    if err is not None:
        raise err
    for flag, g in (("ko", "K_o"), ("kq", "K_q"), ("beta", "beta")):
        v = getattr(args, flag)
        if v is None:
            continue
        err = gain_key_error(sp, schema, f"--{flag}", [g])
        if err is not None:
            raise err
        if g in given:
            raise InputError(f"expected {g} once, received it as --gain and as --{flag}")
        given[g] = v
    box: dict[str, Any] = {"name": "standard"}
    for g in schema.box:
        if g in given:
            r = parse_gain_range(given[g], g)
            box[g] = [str(r.lo), str(r.hi)]
        elif (rng := sp.decl.gain(g).range) is not None:
            box[g] = [str(rng.lo), str(rng.hi)]
        elif g in DEFAULT_BOX:
            box[g] = DEFAULT_BOX[g]
        else:
            raise InputError(f"expected --gain {g}=LO:HI (design {sp.name} declares no range for "
                             f"{g}), received none")
    return box


def _ref_from_flags(text: str, sp: Any, schema: Any) -> dict[str, str]:
    """``--ref``: ``NAME=X`` pairs or the values in the design's controller-gain order."""
    from formsync_design.gains import parse_number
    from formsync_design.sweep.designs import gain_key_error

    parts = [t.strip() for t in text.split(",")]
    named = ["=" in t for t in parts]
    if any(named) and not all(named):
        raise InputError(f"expected --ref NAME=X,NAME=X or the values {','.join(schema.box)}, "
                         f"received {text!r}")
    if all(named):
        items = [(t.split("=", 1)[0].strip(), t.split("=", 1)[1].strip()) for t in parts]
        names = [n for n, _ in items]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise InputError(f"expected each gain once in --ref, received {dup[0]} twice")
        err = gain_key_error(sp, schema, "--ref", names)
        if err is not None:
            raise err
        vals = dict(items)
        missing = [g for g in schema.box if g not in vals]
        if missing:
            raise InputError(f"expected --ref with every controller gain of design {sp.name} "
                             f"({', '.join(schema.box)}), missing {missing}")
    else:
        if len(parts) != len(schema.box):
            raise InputError(f"expected --ref {','.join(schema.box)} ({len(schema.box)} numbers for "
                             f"design {sp.name}), received {text!r}")
        vals = dict(zip(schema.box, parts))
    return {g: str(parse_number(vals[g], f"--ref {g}")) for g in schema.box}


def _campaign_from_flags(args: argparse.Namespace) -> Any:
    from formsync_design.sweep.campaign import campaign_from_dict
    from formsync_design.sweep.designs import check_sweepable, load_design

    sp = load_design(args.spec)
    schema = check_sweepable(sp)
    doc: dict[str, Any] = {"campaign": {"name": args.name or "sweep", "graphs": args.graphs or []}}
    if args.conditions:
        doc["campaign"]["conditions"] = args.conditions
    if args.margin is not None:
        doc["campaign"]["margin"] = args.margin
    doc["box"] = [_box_from_flags(args, sp, schema)]
    if args.ref is not None:
        doc["reference"] = _ref_from_flags(args.ref, sp, schema)
    if args.resolution is not None:
        doc["region"] = {"resolution": args.resolution}
    if args.design_betas is not None:
        doc["design"] = {"betas": args.design_betas}
    mc_flags = (args.mc_seed, args.mc_gains, args.mc_tf, args.mc_case)
    if args.mc_runs is not None or any(v is not None for v in mc_flags):
        if args.mc_runs is None:
            raise InputError("expected --mc-runs N with the other --mc-* options, received none")
        mc: dict[str, Any] = {"runs": args.mc_runs}
        if args.mc_seed is not None:
            mc["seed"] = args.mc_seed
        if args.mc_gains is not None:
            mc["gains"] = args.mc_gains
        if args.mc_tf is not None:
            from formsync_design.cli.options import parse_positive

            mc["tf"] = parse_positive(args.mc_tf, "--mc-tf")
        if args.mc_case is not None:
            mc["case"] = args.mc_case
        doc["montecarlo"] = mc
    return campaign_from_dict(doc, spec=sp if args.spec else None)


def _command(args: argparse.Namespace) -> str:
    """The reproducible part of the command line (execution flags left out)."""
    if args.campaign:
        parts = ["--campaign", args.campaign]
    else:
        parts = []
        for g in args.graphs or []:
            parts += ["--graphs", g]
        for f in _DEF_FLAGS:
            v = getattr(args, f)
            if f not in ("graphs", "gain") and v is not None:
                parts += ["--" + f.replace("_", "-"), str(v)]
        for gv in args.gain or []:
            parts += ["--gain", gv]
    if args.spec:
        parts += ["--design", args.spec]
    return shlex.join(["formsync", "sweep", *parts, "--out", args.out, "--overwrite"])


def _flag_defaults(args: argparse.Namespace) -> int | None:
    """``formsync sweep --design NAME`` alone: the graph families ring, path and star at the
    size of the design's shipped case, an agent design's gains not given fixed at the case's
    values but two (at most three free axes counting the searched multipliers), the folder
    ``out/sweep-<design>``; each said on stderr.  Exit status 1 (returned) when the sweep does
    not apply to the design."""
    from formsync_design.cli.defaults import (
        agent_box,
        default_out,
        refuse_tracking,
        refuse_uncertified,
    )
    from formsync_design.sweep.designs import load_design
    from formsync_design.verify.defaults import Defaults

    design = load_design(args.spec)
    refused = refuse_tracking("sweep", design, "a sweep over communication graphs") or \
        refuse_uncertified("sweep", design)
    if refused is not None:
        return refused
    defaults = Defaults()
    if getattr(design, "form", None) == "agent":
        from formsync_design.cli.agent_inputs import agent_case_for

        case = agent_case_for(design, None, None, defaults)
        n = case.n
        if not args.gain:
            box = agent_box(design, None, case, defaults, free=2)
            args.gain = [f"{r.name}={r.lo}:{r.hi}" if r.lo != r.hi else f"{r.name}={r.lo}"
                         for r in box.ranges]
    else:
        from formsync_design.verify.defaults import lagrangian_case_for

        n = lagrangian_case_for(design, None, defaults).n
    if not args.graphs:
        args.graphs = [f"ring:{n}", f"path:{n}", f"star:{n}"]
        if getattr(design, "form", None) == "agent" and design.decl.leader:
            from formsync_design.cli.defaults import not_applicable
            from formsync_design.derive.agent import agent_conditions
            from formsync_design.errors import DerivationError

            try:  # the default families pin no spacecraft: does the certificate take them?
                agent_conditions(design, f"ring:{n}")
            except DerivationError as e:
                return not_applicable("sweep", f"design {design.name} follows a leader and its "
                                      f"certificate does not take the unpinned graph ring:{n} "
                                      f"({str(e).split(': ')[-1]}); give --graphs with edge-list "
                                      "files that pin the leader")
        defaults.add(f"graphs {', '.join(args.graphs)} (the size of the design's case, "
                     f"{n} spacecraft; give --graphs SET for others)")
    if not args.out:
        args.out = str(default_out("sweep", design))
        defaults.add(f"results folder {args.out} (give --out DIR for another)")
    defaults.emit("sweep")
    return None


def run(args: argparse.Namespace) -> int:
    from formsync_design.cli.options import parse_positive
    from formsync_design.sweep import load_campaign, run_sweep

    timeout = parse_positive(args.timeout, "--timeout")
    if args.campaign:
        used = [f for f in _DEF_FLAGS if getattr(args, f) is not None]
        if used:
            raise InputError(
                "expected either --campaign FILE or campaign flags, received both (--campaign and "
                + ", ".join("--" + f.replace("_", "-") for f in used) + ")"
            )
        if not args.out:
            raise InputError("expected --out DIR with --campaign FILE, received none")
        camp = load_campaign(args.campaign, spec=args.spec)
    else:
        if not args.graphs and args.spec is None:
            raise InputError("expected --campaign FILE or at least one --graphs SET, received neither")
        if not args.graphs or not args.out:
            refused = _flag_defaults(args)
            if refused is not None:
                return refused
        camp = _campaign_from_flags(args)
    # the bar is up before the first task ends (its elapsed time moves while a long task runs,
    # e.g. a graph of 2000 spacecraft); the count of tasks is known from the first finished one
    prog = Progress(None, "sweep tasks", unit="task", tick=True,
                    enabled=not args.no_progress and args.format == "text")

    def progress(done: int, total: int) -> None:
        if prog.total is None:
            prog.set_total(total)
        prog.update(done - prog.done)

    try:
        res = run_sweep(
            camp, args.out, resume=args.resume, overwrite=args.overwrite, scheduler=args.scheduler,
            n_workers=args.workers, timeout=timeout, progress=progress, command=_command(args),
        )
    except KeyboardInterrupt:
        prog.close()  # the bar's line is cleared before the message
        journal = Path(args.out) / "journal.jsonl"
        kept = f"finished rows are kept in {journal}; " if journal.is_file() else ""
        sys.stderr.write(f"formsync sweep: interrupted (Ctrl-C); {kept}the same command with "
                         "--resume completes the campaign\n")
        return EXIT_INTERRUPTED
    finally:
        prog.close()  # also when no task was pending, or a task failed
    if args.format == "json":
        emit_json({
            "out": str(res.out), "sha256": res.sha256, "design": res.design, "graphs": res.graphs,
            "tasks": res.tasks,
            "computed": res.computed, "reused": res.reused, "skipped": list(res.skipped),
            "executor": res.executor, "wall_seconds": res.wall_seconds,
            "files": [str(p) for p in res.files],
        })
    else:
        rate = res.computed / res.wall_seconds if res.wall_seconds > 0 else 0.0
        print(f"sweep {camp.name} (design {res.design}): {res.tasks} tasks ({res.graphs} graphs x "
              f"{len(camp.boxes)} boxes); "
              f"computed {res.computed}, reused {res.reused}; {res.wall_seconds:.1f} s "
              f"({rate:.2f} tasks/s) on {res.executor}")
        if res.skipped:
            print(f"skipped {len(res.skipped)} graphs: {', '.join(res.skipped)}")
        for p in res.files:
            print(f"wrote {p}")
    sys.stdout.flush()
    return EXIT_OK
