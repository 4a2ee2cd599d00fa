"""`mound data` and `mound classify`: the public data sets and the coarse-search classifier."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING, Any

from mound import datasets
from mound.args import command_group
from mound.bounds import (
    SEED,
    Bound,
)
from mound.classify.defaults import DEFAULT_BAND, DEFAULT_L2
from mound.jsonio import write_json

if TYPE_CHECKING:
    from mound.classify.coarse import Evaluation


def cmd_fetch(args: argparse.Namespace) -> int:
    where = datasets.fetch(datasets.STATLOG, url=args.url)
    print(f"statlog: {', '.join(datasets.STATLOG.files)} in {where} (sha256 checked)")
    return 0


def cmd_bands(args: argparse.Namespace) -> int:
    from mound.classify import coarse, statlog  # scipy: imported when a command needs it

    rows = coarse.select_band(statlog.load("sat.trn"), seed=args.seed)
    print("held-out evaluation on sat.trn (75/25 stratified split, L-BFGS):")
    print(f"{'features':<18} {'AUC':>7} {'accuracy':>9} {'log-loss':>9}")
    for r in rows:
        label = r["name"] if r["band"] is None else f"band {r['band']} {r['name']}"
        print(f"{label:<18} {r['auc']:>7.4f} {r['accuracy']:>9.4f} {r['log_loss']:>9.4f}")
    best = max((r for r in rows if r["band"] is not None), key=lambda r: r["auc"])
    print(f"best single band: {best['band']} ({best['name']})")
    return 0


def cmd_train(args: argparse.Namespace) -> int:
    from mound.classify import coarse, statlog

    band = None if args.all else args.band
    model = coarse.train(statlog.load("sat.trn"), band, solver=args.solver, l2=args.l2)
    write_json(args.out, model.to_doc())
    i = model.info
    print(f"trained {'all 36 features' if band is None else f'band {band}'} with {args.solver}: "
          f"{i['iterations']} iterations, {i['train_seconds']:.3f} s, loss {i['loss']:.5f}, "
          f"|grad| {i['grad_norm']:.2e} -> {args.out}")
    return 0


def print_eval(s: Evaluation) -> None:
    print(f"sat.tst ({s['rows']} rows): accuracy {s['accuracy']:.4f} "
          f"(majority baseline {s['majority_accuracy']:.4f}), AUC {s['auc']:.4f}, "
          f"log-loss {s['log_loss']:.4f}, ECE {s['ece']:.4f}")
    print("reliability:   p range   count  mean p  observed")
    for r in s["reliability"]:
        if r["count"]:
            print(f"             {r['lo']:.1f}-{r['hi']:.1f} {r['count']:>7} "
                  f"{r['mean_p']:>7.3f} {r['observed']:>9.3f}")


def cmd_eval(args: argparse.Namespace) -> int:
    from mound.classify import coarse, statlog

    s = coarse.evaluate(coarse.load_model(args.model), statlog.load("sat.tst"))
    print_eval(s)
    if args.json:
        write_json(args.json, {"schema": "mound.classifier_eval", "version": 1, **{
            k: v for k, v in s.items() if k != "reliability"},
            "reliability": [r for r in s["reliability"] if r["count"]]})
    return 0


def add_parser(sub: Any, parser_class: Any) -> None:
    """The `data` and `classify` command groups."""
    data = command_group(sub, "data", "public data sets", parser_class)
    f = data.add_parser("fetch", help="download Statlog into the cache ($MOUND_DATA)")
    f.add_argument("--url", help="archive URL (default: UCI)")
    f.set_defaults(func=cmd_fetch)

    cls = command_group(sub, "classify", "coarse-search classifier", parser_class)
    b = cls.add_parser("bands", help="held-out comparison of the bands on sat.trn")
    b.add_argument("--seed", type=SEED.arg(), default=0)
    b.set_defaults(func=cmd_bands)
    t = cls.add_parser("train", help="train on sat.trn")
    g = t.add_mutually_exclusive_group()
    g.add_argument("--band", type=int, choices=range(4), default=DEFAULT_BAND)
    g.add_argument("--all", action="store_true", help="all 36 features")
    t.add_argument("--solver", choices=("gd", "lbfgs"), default="gd")
    t.add_argument("--l2", type=Bound(0, 1e6).arg(), default=DEFAULT_L2)
    t.add_argument("--out", required=True)
    t.set_defaults(func=cmd_train)
    e = cls.add_parser("eval", help="evaluate on sat.tst")
    e.add_argument("model")
    e.add_argument("--json", help="also write the figures as JSON")
    e.set_defaults(func=cmd_eval)
