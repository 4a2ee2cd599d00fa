"""`mound photos sort` (issue 28, first part) on real geotagged photos: the Caliterra
survey (a Canon with EXIF GPS) and fountain-P11 (no GPS), and a card made from Caliterra's
photos with the faults a real card has (a duplicate, a truncated file, a blurred frame,
transit shots, a photo from far away, another day's photo, a text file). The photos' EXIF
is rewritten with Pillow, and the sorter reads it with the project's own reader
(mound_recon photos)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from PIL import Image, ImageFilter
from PIL.TiffImagePlugin import IFDRational

from mound import native
from mound.cli import main as mound_main
from mound.errors import InputError
from mound.photos.sort import SortSpec, sort_card


@pytest.fixture(scope="module")
def caliterra(shared_data: Path) -> Path:
    return shared_data / "images" / "caliterra" / "images"


def sites_at(caliterra: Path, tmp: Path) -> Path:
    """A mound.sites document with one site at the centre of the photos' GPS positions and
    one 1 km east of it."""
    listing = native.run_json("mound_recon", ["photos", str(caliterra)])
    ll = np.array([[f["exif"]["lat"], f["exif"]["lon"]] for f in listing["files"]
                   if "lat" in f["exif"]])
    lat, lon = ll.mean(axis=0)
    doc = {"schema": "mound.sites", "version": 1,
           "origin": {"lat": float(lat), "lon": float(lon), "alt_m": 0.0},
           "home": {"id": "home", "x_m": -150.0, "y_m": 0.0}, "budget_m": 1000.0,
           "sites": [{"id": "here", "x_m": 0.0, "y_m": 0.0, "reward": 1.0},
                     {"id": "far", "x_m": 1000.0, "y_m": 0.0, "reward": 1.0}]}
    path = tmp / "sites.json"
    path.write_text(json.dumps(doc))
    return path


def test_caliterra_lands_in_the_site_at_its_centre(caliterra: Path, tmp_path: Path) -> None:
    sites = sites_at(caliterra, tmp_path)
    out = tmp_path / "sorted"
    doc = sort_card(str(caliterra.parent), str(sites), str(out), SortSpec(site_diameter_m=100))
    by = {r["file"]: r for r in doc["photos"]}
    jpgs = [f for f in by if f.endswith(".jpg")]
    assert len(jpgs) == 40
    assert all(by[f]["site"] == "here" and by[f]["reason"] is None for f in jpgs)
    assert doc["sites"]["far"]["photos"] == 0 and doc["sites"]["here"]["photos"] == 40
    assert all(by[f]["reason"] == "not_an_image" for f in by if not f.endswith(".jpg"))
    links = sorted(p.name for p in (out / "here").iterdir())
    assert len(links) == 40
    assert (out / "here" / links[0]).resolve().is_relative_to(caliterra.resolve())
    assert not (out / "far").exists()
    assert json.loads((out / "photos.json").read_text())["schema"] == "mound.photos"


def test_fountain_has_no_gps(shared_data: Path, caliterra: Path, tmp_path: Path,
                             capsys: pytest.CaptureFixture[str]) -> None:
    """Strecha's fountain-P11: no GPS in its EXIF; nothing usable, exit 2 naming why."""
    sites = sites_at(caliterra, tmp_path)
    card = shared_data / "images" / "fountain-P11" / "images"
    code = mound_main(["photos", "sort", str(card), "--sites", str(sites),
                       "--out", str(tmp_path / "f")])
    err = capsys.readouterr().err
    assert code == 2 and "no usable photo over any site" in err and "no_gps" in err
    assert not (tmp_path / "f" / "photos.json").exists()


def _moved(src: Path, dst: Path, east_m: float = 0.0, day: str | None = None,
           blur: bool = False) -> None:
    """A copy of a photo with its GPS moved east by `east_m`, its capture day changed, or
    its pixels blurred (the EXIF kept)."""
    im = Image.open(src)
    ex = im.getexif()
    if east_m:
        gps = ex.get_ifd(0x8825)
        d, m, s = (float(v) for v in gps[4])
        lon = d + m / 60 + s / 3600
        lon -= east_m / (111_320 * np.cos(np.radians(30.17)))  # west longitude: east is less
        d2 = int(lon)
        m2 = int((lon - d2) * 60)
        s2 = (lon - d2 - m2 / 60) * 3600
        gps[4] = (IFDRational(d2), IFDRational(m2), IFDRational(round(s2 * 1000), 1000))
    if day:
        ex.get_ifd(0x8769)[36867] = f"{day} 12:00:00"
    if blur:
        im = im.filter(ImageFilter.GaussianBlur(12))
    im.save(dst, exif=ex, quality=90)


def test_a_card_with_the_faults_of_a_real_one(caliterra: Path, tmp_path: Path) -> None:
    sites = sites_at(caliterra, tmp_path)
    card = tmp_path / "card"
    dcim = card / "DCIM" / "100CANON"
    dcim.mkdir(parents=True)
    photos = sorted(caliterra.glob("*.jpg"))[:12]
    for p in photos:
        shutil.copy(p, dcim / p.name)
    shutil.copy(photos[0], dcim / "ZZ_COPY_OF_FIRST.JPG")                         # duplicate
    (dcim / "CUT.JPG").write_bytes(photos[1].read_bytes()[:30_000])              # truncated
    _moved(photos[2], dcim / "BLUR.JPG", blur=True)                             # blurred
    _moved(photos[3], dcim / "TRANSIT.JPG", east_m=400)                         # on the way
    _moved(photos[4], dcim / "FAR.JPG", east_m=50_000)                          # elsewhere
    _moved(photos[5], dcim / "OTHERDAY.JPG", day="2014:11:02")                  # another day
    (card / "MISC").mkdir()
    (card / "MISC" / "readme.txt").write_text("not a photo")
    out = tmp_path / "sorted"
    doc = sort_card(str(card), str(sites), str(out), SortSpec(site_diameter_m=100))
    by = {Path(r["file"]).name: r for r in doc["photos"]}
    assert by["ZZ_COPY_OF_FIRST.JPG"]["reason"] == "duplicate"
    assert by["ZZ_COPY_OF_FIRST.JPG"]["duplicate_of"].endswith(photos[0].name)
    assert by["CUT.JPG"]["reason"] == "unreadable"  # its EXIF is whole, its pixels are not
    assert by["BLUR.JPG"]["site"] is None and by["BLUR.JPG"]["reason"] == "blurred"
    assert by["BLUR.JPG"]["over_site"] == "here"
    assert by["TRANSIT.JPG"]["reason"] == "transit"
    assert by["FAR.JPG"]["reason"] == "outside_sites"
    assert by["OTHERDAY.JPG"]["reason"] == "other_flight"
    assert by["readme.txt"]["reason"] == "not_an_image"
    good = [p.name for p in photos]
    assert all(by[n]["site"] == "here" and by[n]["reason"] is None for n in good)
    assert doc["sites"]["here"] == {**doc["sites"]["here"], "photos": 12, "blurred": 1,
                                    "status": "ok"}
    assert sorted(p.name for p in (out / "here").iterdir()) == sorted(
        f"DCIM__100CANON__{n}" for n in good)
    # The card is untouched.
    assert sorted(p.name for p in dcim.iterdir()) == sorted(
        [*good, "ZZ_COPY_OF_FIRST.JPG", "CUT.JPG", "BLUR.JPG", "TRANSIT.JPG", "FAR.JPG",
         "OTHERDAY.JPG"])


def test_bad_arguments(caliterra: Path, tmp_path: Path,
                       capsys: pytest.CaptureFixture[str]) -> None:
    sites = sites_at(caliterra, tmp_path)
    with pytest.raises(InputError, match="not a folder"):
        sort_card(str(tmp_path / "nothing"), str(sites), str(tmp_path / "o"))
    (tmp_path / "empty").mkdir()
    with pytest.raises(InputError, match="an empty card"):
        sort_card(str(tmp_path / "empty"), str(sites), str(tmp_path / "o"))
    (tmp_path / "x.json").write_text('{"schema": "mound.verdict", "version": 1}')
    with pytest.raises(InputError, match="mound.plan or mound.sites"):
        sort_card(str(caliterra), str(tmp_path / "x.json"), str(tmp_path / "o"))
    with pytest.raises(InputError, match="--blur-ratio"):
        sort_card(str(caliterra), str(sites), str(tmp_path / "o"), SortSpec(blur_ratio=-1))
