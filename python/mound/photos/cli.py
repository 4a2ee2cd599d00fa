"""`mound photos sort`: the photo card stage of the command line."""

from __future__ import annotations

import argparse
from typing import Any

from mound.args import command_group
from mound.geometry.flight import DEFAULT_SITE_DIAMETER_M
from mound.photos.sort import SORT_NUMBERS


def cmd_sort(args: argparse.Namespace) -> int:
    from mound.photos.sort import SortSpec, sort_card

    spec = SortSpec(site_diameter_m=args.site_diameter_m, margin_m=args.margin_m,
                    max_gap_h=args.max_gap_h, blur_ratio=args.blur_ratio, copy=args.copy)
    doc = sort_card(args.card, args.plan or args.sites, args.out, spec, args.camera)
    counts = ", ".join(f"{n} {k}" for k, n in sorted(doc.counts.items()))
    print(f"{doc.files} files: {counts} -> {args.out}/photos.json")
    if doc.proposed:
        p = doc.proposed
        print(f"  no sites file: {len(p.sites)} sites proposed from the photos (spacing "
              f"{p.spacing_m:.1f} m, linked within {p.link_m:.1f} m; home at "
              f"{p.home}) -> {args.out}/sites.json")
    for sid, info in doc.sites.items():
        if info.photos or info.blurred:
            print(f"  {sid}: {info.photos} photos ({info.blurred} blurred), "
                  f"{info.status}, camera {info.camera.get('source')}")
    return 0


def add_parser(sub: Any, parser_class: type) -> None:
    grp = command_group(sub, "photos", "photos from the aircraft's card", parser_class)
    s = grp.add_parser("sort", help="sort a photo card into the scanned sites (links)")
    s.add_argument("card", help="the card's folder (DCIM tree or a copy); never changed")
    src = s.add_mutually_exclusive_group()
    src.add_argument("--plan", help="plan.json of the flights (their sites and scan)")
    src.add_argument("--sites", help="the sites: a mound.sites document or a GeoJSON "
                     "(what mound scene score --home writes; python/mission.py --sites). "
                     "Neither: the sites are proposed from the photos (a crew that flew "
                     "by hand) and written as OUT/sites.json")
    s.add_argument("--out", required=True, help="folder: photos.json and <site id>/")
    s.add_argument("--site-diameter", dest="site_diameter_m", metavar="D",
                   type=SORT_NUMBERS["site_diameter_m"][1].arg(),
                   default=DEFAULT_SITE_DIAMETER_M,
                   help="the scan's scale where the plan has no scan, m (default 60)")
    s.add_argument("--margin-m", type=SORT_NUMBERS["margin_m"][1].arg(), default=10.0,
                   help="GPS error allowed around a scan area, m (default 10)")
    s.add_argument("--max-gap-h", type=SORT_NUMBERS["max_gap_h"][1].arg(), default=6.0,
                   help="photos this many hours from the card's median time are another "
                   "flight's (default 6)")
    s.add_argument("--blur-ratio", type=SORT_NUMBERS["blur_ratio"][1].arg(), default=0.3,
                   help="blurred: sharpness below this share of the site's median "
                   "(default 0.3)")
    s.add_argument("--copy", action="store_true", help="copy the photos instead of linking")
    s.add_argument("--camera", help="the camera (mound.camera v1), copied into each site's "
                   "folder (default: from the photos' EXIF)")
    s.set_defaults(func=cmd_sort)
