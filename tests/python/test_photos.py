"""`mound photos sort` (issue 28, first part) on real geotagged photos: the Caliterra
survey (a Canon with EXIF GPS) and fountain-P11 (no GPS), and a card made from Caliterra's
photos with the faults a real card has (a duplicate, a truncated file, a blurred frame,
transit shots, a photo from far away, another day's photo, a text file). The photos' EXIF
is rewritten with Pillow, and the sorter reads it with the project's own reader
(mound_recon photos)."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from PIL import Image, ImageFilter
from PIL.TiffImagePlugin import IFDRational

from mound import native
from mound.cli import main as mound_main
from mound.errors import InputError
from mound.paths import build_dir
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


def test_the_sites_of_a_scene_s_geojson_sort_a_card_as_their_mound_sites_document(
        tmp_path: Path) -> None:
    """`--sites` is read by one reader in every command (issue 57): the WGS84 GeoJSON that
    `mound scene score --home` writes (and python/mission.py --sites reads) gives `mound
    photos sort` the same sites, in the same local frame, as the mound.sites document of
    the same places; p_mound is not needed to sort photos."""
    from mound.geometry.geodesy import Origin, enu_to_geodetic
    from mound.photos.sort import sites_of

    home = Origin(42.6231, 25.3942, 310.0)
    enu = np.array([[0.0, 0.0, 0.0], [250.0, -40.0, 0.0], [1000.0, 300.0, 0.0]])
    llh = enu_to_geodetic(home, enu)
    geo = {"type": "FeatureCollection", "features": [
        {"type": "Feature", "geometry": {"type": "Point", "coordinates": [lon, lat]},
         "properties": {"kind": "home", "alt_m": 310.0} if k == 0 else
         {"id": f"c{k}", "p_mound": 0.5}} for k, (lat, lon, _) in enumerate(llh)]}
    doc = {"schema": "mound.sites", "version": 1, "origin": home.to_doc(),
           "home": {"id": "home", "x_m": 0.0, "y_m": 0.0},
           "sites": [{"id": f"c{k}", "x_m": float(e[0]), "y_m": float(e[1]), "reward": 1.0}
                     for k, e in enumerate(enu) if k]}
    (tmp_path / "c.geojson").write_text(json.dumps(geo))
    (tmp_path / "c.json").write_text(json.dumps(doc))
    a = sites_of(str(tmp_path / "c.geojson"), SortSpec())
    b = sites_of(str(tmp_path / "c.json"), SortSpec())
    assert a.ids == b.ids == ["c1", "c2"]
    assert np.allclose(a.xy, b.xy, atol=1e-3) and np.allclose(a.xy, enu[1:, :2], atol=1e-3)
    assert np.allclose(a.home_xy, [0, 0]) and a.reach_m == b.reach_m > 0
    assert np.allclose([a.origin.lat_deg, a.origin.lon_deg, a.origin.alt_m],
                       [b.origin.lat_deg, b.origin.lon_deg, b.origin.alt_m], atol=1e-9)


@pytest.mark.slow
def test_caliterra_lands_in_the_site_at_its_centre(caliterra: Path, tmp_path: Path) -> None:
    sites = sites_at(caliterra, tmp_path)
    out = tmp_path / "sorted"
    doc = sort_card(str(caliterra.parent), str(sites), str(out),
                    SortSpec(site_diameter_m=100)).doc
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


@pytest.mark.slow
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
    doc = sort_card(str(card), str(sites), str(out), SortSpec(site_diameter_m=100)).doc
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
    with pytest.raises(InputError, match="mound.plan, a mound.sites document or a GeoJSON"):
        sort_card(str(caliterra), str(tmp_path / "x.json"), str(tmp_path / "o"))
    with pytest.raises(InputError, match="--blur-ratio"):
        sort_card(str(caliterra), str(sites), str(tmp_path / "o"), SortSpec(blur_ratio=-1))


@pytest.fixture(scope="module")
def sim_card(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """A planned flight over two simulated sites (a tumulus and flat ground) written as the
    aircraft's card (mound sim flight): JPEGs with EXIF, transit frames between the sites."""
    from dataclasses import replace

    from mound.geometry.flight import scan_for_site
    from mound.sim.card import CardSpec, write_card

    tmp = tmp_path_factory.mktemp("simcard")
    scan = replace(scan_for_site(60.0, "raster"), width_px=160, height_px=120)
    sites = {"schema": "mound.sites", "version": 1,
             "origin": {"lat": 38.5705, "lon": 27.9862, "alt_m": 95.0},
             "home": {"id": "home", "x_m": 0.0, "y_m": 0.0}, "budget_m": 3000.0,
             "scan": scan.to_doc(), "takeoff_landing_m": scan.takeoff_landing_m(),
             "sites": [{"id": "a", "x_m": 300.0, "y_m": 0.0, "reward": 1.0,
                        "scan_cost_m": scan.site_cost_m(), "truth": {"mound": True}},
                       {"id": "b", "x_m": 300.0, "y_m": 400.0, "reward": 0.9,
                        "scan_cost_m": scan.site_cost_m(), "truth": {"mound": False}}]}
    (tmp / "sites.json").write_text(json.dumps(sites))
    native.run_tool("mound_plan", [str(tmp / "sites.json"), "--out", str(tmp / "plan.json")])
    truth = write_card(str(tmp / "plan.json"), str(tmp / "sites.json"), str(tmp / "card"),
                       CardSpec(image_size=(160, 120)))
    return {"dir": tmp, "truth": truth.to_doc()}


@pytest.mark.slow
def test_simulated_jpegs_carry_what_a_camera_writes(sim_card: dict[str, Any]) -> None:
    """The project's EXIF reader finds in the simulated card what the simulator put there:
    GPS to a millimetre, the capture time, the focal length in pixels exactly."""
    from mound.geometry.geodesy import Origin, geodetic_to_enu

    listing = native.run_json("mound_recon", ["photos", str(sim_card["dir"] / "card")])
    truth = {f["file"]: f for f in sim_card["truth"]["files"]}
    assert [f["file"] for f in listing["files"]] == sorted(truth)
    origin = Origin.from_doc({"lat": 38.5705, "lon": 27.9862, "alt_m": 95.0})
    for f in listing["files"]:
        x = f["exif"]
        assert f["kind"] == "jpeg" and x["make"] == "mound-survey"
        assert x["time"] == truth[f["file"]]["time"].replace("-", ":").replace("T", " ")
        assert x["focal_source"] == "focal_plane"
        enu = geodetic_to_enu(origin, np.array([[x["lat"], x["lon"], x["alt_m"]]]))[0]
        site = truth[f["file"]]["site"]
        centre = {"a": (300, 0), "b": (300, 400)}.get(site)
        if centre:  # a site's photo: within the scan's reach plus GPS noise (1 m sigma)
            reach = sim_card["truth"]["spec"]["reach_m"]
            assert np.hypot(enu[0] - centre[0], enu[1] - centre[1]) < reach + 5
            assert abs(x["focal_px"] - 160 / 2 / np.tan(np.radians(35))) < 1e-3
    assert {f["site"] for f in truth.values()} == {"a", "b", None}
    assert sum(1 for f in truth.values() if f["reason"] == "transit") >= 5


def _rewritten(src: Path, dst: Path, **change: Any) -> None:
    """A copy of a JPEG with its EXIF GPS changed (lat, lon, alt_m), removed (gps=None) or
    its pixels blurred (blur=True)."""
    im = Image.open(src)
    ex = im.getexif()
    gps = ex.get_ifd(0x8825)
    if change.get("gps", True) is None:
        gps.clear()
    if "lat" in change:
        gps[2] = (IFDRational(0), IFDRational(0), IFDRational(0))
        gps[4] = (IFDRational(0), IFDRational(0), IFDRational(0))
    if "alt_m" in change:
        gps[5], gps[6] = b"\x01", IFDRational(9999)
    if change.get("blur"):
        im = im.filter(ImageFilter.GaussianBlur(6))
    im.save(dst, exif=ex, quality=95)


@pytest.mark.slow
def test_a_simulated_card_sorts_exactly_right(sim_card: dict[str, Any], tmp_path: Path) -> None:
    """Two sites and the transit frames as the simulator wrote them, plus the faults of a
    real card: a GPS-less photo, GPS 0, 0, an altitude of -9999 m, a truncated file, a
    duplicate and a blurred frame; every file gets the site or reason it should."""
    card = tmp_path / "card"
    shutil.copytree(sim_card["dir"] / "card", card)
    media = card / "DCIM" / "100MEDIA"
    expect = {f["file"]: (f["site"], f["reason"]) for f in sim_card["truth"]["files"]}
    a_photos = sorted(f for f, (s, _) in expect.items() if s == "a")
    src = [card / f for f in a_photos[:5]]
    _rewritten(src[0], media / "NOGPS.JPG", gps=None)
    _rewritten(src[1], media / "ZERO.JPG", lat=0)
    _rewritten(src[2], media / "DEEP.JPG", alt_m=-9999)
    (media / "CUT.JPG").write_bytes(src[3].read_bytes()[:3000])
    shutil.copy(src[4], media / "ZZCOPY.JPG")
    _rewritten(src[4], media / "BLUR.JPG", blur=True)
    pre = "DCIM/100MEDIA/"
    expect.update({pre + "NOGPS.JPG": (None, "no_gps"), pre + "ZERO.JPG": (None, "no_gps"),
                   pre + "DEEP.JPG": ("a", None), pre + "CUT.JPG": (None, "unreadable"),
                   pre + "ZZCOPY.JPG": (None, "duplicate"), pre + "BLUR.JPG": (None, "blurred")})
    out = tmp_path / "sorted"
    doc = sort_card(str(card), str(sim_card["dir"] / "plan.json"), str(out)).doc
    got = {r["file"]: (r["site"], r["reason"]) for r in doc["photos"]}
    assert got == expect
    rows = {r["file"]: r for r in doc["photos"]}
    assert rows[pre + "DEEP.JPG"]["alt_m"] is None  # the lie is dropped, the photo kept
    assert rows[pre + "BLUR.JPG"]["over_site"] == "a"
    n_a = sum(1 for s, r in expect.values() if s == "a" and r is None)
    assert doc["sites"]["a"]["photos"] == n_a and doc["sites"]["a"]["status"] == "ok"
    assert doc["sites"]["a"]["camera"]["source"] == "exif (focal_plane)"
    assert len(list((out / "a").iterdir())) == n_a
    # A camera file, when given, goes into each site's folder.
    cam = tmp_path / "camera.json"
    cam.write_text(json.dumps({"schema": "mound.camera", "version": 1, "width": 160,
                               "height": 120, "K": [[114, 0, 79.5], [0, 114, 59.5], [0, 0, 1]],
                               "dist": [0, 0, 0, 0, 0]}))
    doc = sort_card(str(card), str(sim_card["dir"] / "plan.json"), str(out),
                    camera=str(cam)).doc
    assert doc["sites"]["b"]["camera"]["source"] == "file"
    assert json.loads((out / "b" / "camera.json").read_text())["K"][0][0] == 114


@pytest.mark.slow
def test_sim_site_jpeg(tmp_path: Path) -> None:
    """`mound sim site --jpeg`: the site's images as JPEGs (no PNG left), poses.json naming
    them, each one's EXIF GPS the simulator's noisy GPS position (to a millimetre) and its
    time one shot interval after the one before."""
    from mound.geometry.geodesy import Origin, geodetic_to_enu

    out = tmp_path / "site"
    assert mound_main(["sim", "site", "--size", "160", "120", "--pattern", "raster",
                       "--jpeg", "--start-time", "2026-07-01T10:00:00", "--out",
                       str(out)]) == 0
    assert not list((out / "images").glob("*.png"))
    poses = json.loads((out / "poses.json").read_text())
    listing = native.run_json("mound_recon", ["photos", str(out / "images")])
    by = {f["file"]: f["exif"] for f in listing["files"]}
    origin = Origin.from_doc(poses["origin"])
    for k, im in enumerate(poses["images"]):
        x = by[Path(im["file"]).name]
        enu = geodetic_to_enu(origin, np.array([[x["lat"], x["lon"], x["alt_m"]]]))[0]
        assert np.allclose(enu, im["gps_enu_m"], atol=2e-3)
        assert x["time"] == f"2026:07:01 10:00:{2 * k:02d}"


def _dji_xmp(abs_alt: float, rel_alt: float, lat: float | None = None,
             lon: float | None = None) -> bytes:
    gps = (f' drone-dji:GpsLatitude="{lat:+.8f}" drone-dji:GpsLongitude="{lon:+.8f}"'
           if lat is not None and lon is not None else "")
    return ('<?xpacket begin="\ufeff" id="W5M0MpCehiHzreSzNTczkc9d"?>'
            '<x:xmpmeta xmlns:x="adobe:ns:meta/"><rdf:RDF xmlns:rdf='
            '"http://www.w3.org/1999/02/22-rdf-syntax-ns#"><rdf:Description rdf:about='
            '"DJI Meta Data" xmlns:drone-dji="http://www.dji.com/drone-dji/1.0/"'
            f' drone-dji:AbsoluteAltitude="{abs_alt:+.3f}"'
            f' drone-dji:RelativeAltitude="{rel_alt:+.3f}"'
            ' drone-dji:GimbalRollDegree="+0.00" drone-dji:GimbalYawDegree="+45.10"'
            ' drone-dji:GimbalPitchDegree="-89.90" drone-dji:FlightRollDegree="+1.20"'
            ' drone-dji:FlightYawDegree="+44.70" drone-dji:FlightPitchDegree="-2.30"'
            ' drone-dji:RtkFlag="50" drone-dji:RtkStdLon="0.01134"'
            f' drone-dji:RtkStdLat="0.01245" drone-dji:RtkStdHgt="0.02517"{gps}/>'
            '</rdf:RDF></x:xmpmeta><?xpacket end="w"?>').encode()


def test_dji_photos_xmp_is_read_and_a_contradiction_reported(caliterra: Path,
                                                            tmp_path: Path) -> None:
    """Caliterra's photos given a DJI XMP packet (drone-dji: heights, attitude, RTK): every
    field reaches photos.json; a photo whose XMP height and position contradict its EXIF
    is reported (the EXIF kept, never merged), and the take-off height's spread over the
    card (AbsoluteAltitude - RelativeAltitude) measured."""
    card = tmp_path / "card" / "DCIM" / "100MEDIA"
    card.mkdir(parents=True)
    listing = native.run_json("mound_recon", ["photos", str(caliterra)])
    gps = [f for f in listing["files"] if "lat" in f["exif"]][:10]
    for k, f in enumerate(gps):
        im = Image.open(caliterra / f["file"])
        alt = f["exif"].get("alt_m", 100.0)
        lie = k == 3  # XMP 25 m higher and 40 m north of what EXIF says
        xmp = _dji_xmp(alt + (25.0 if lie else 0.0), alt - 60.0,
                       f["exif"]["lat"] + (40 / 111_000 if lie else 0.0), f["exif"]["lon"])
        im.save(card / f"DJI_{k:04d}.JPG", exif=im.info["exif"], xmp=xmp, quality=90)
    sites = sites_at(caliterra, tmp_path)
    doc = sort_card(str(tmp_path / "card"), str(sites), str(tmp_path / "out"),
                    SortSpec(site_diameter_m=100)).doc
    by = {r["file"].split("/")[-1]: r for r in doc["photos"]}
    x = by["DJI_0000.JPG"]["dji_xmp"]
    assert x["rel_alt_m"] == pytest.approx(gps[0]["exif"].get("alt_m", 100.0) - 60.0, abs=1e-3)
    assert (x["gimbal_pitch_deg"], x["gimbal_yaw_deg"], x["gimbal_roll_deg"]) == (-89.9, 45.1, 0)
    assert (x["flight_pitch_deg"], x["flight_yaw_deg"], x["flight_roll_deg"]) == (-2.3, 44.7, 1.2)
    assert (x["rtk_flag"], x["rtk_std_lon_m"], x["rtk_std_lat_m"], x["rtk_std_hgt_m"]) == (
        50, 0.01134, 0.01245, 0.02517)
    assert "xmp_conflicts" not in by["DJI_0000.JPG"]
    bad = by["DJI_0003.JPG"]
    assert len(bad["xmp_conflicts"]) == 2 and "AbsoluteAltitude" in bad["xmp_conflicts"][1]
    assert bad["alt_m"] == pytest.approx(gps[3]["exif"].get("alt_m"), abs=0.01)  # EXIF kept
    s = doc["dji_xmp"]
    assert (s["photos"], s["conflicts"], s["rtk_fixed"]) == (10, 1, 10)
    assert s["altitude_drift"]["spread_m"] == pytest.approx(25.0, abs=0.01)


@pytest.mark.slow
def test_rtk_fixed_dji_photos_are_georegistered_in_three_dimensions(tmp_path: Path) -> None:
    """`mound_recon reconstruct --gps exif` on a simulated site's JPEGs: levelled from the
    images by default (consumer GNSS heights drift); the same photos with DJI XMP saying
    RTK fixed (RtkFlag 50, vertical sigma 2.5 cm) fit all three GPS coordinates, weighted
    by the inverse of each position's RTK variance."""
    out = tmp_path / "site"
    assert mound_main(["sim", "site", "--size", "320", "240", "--pattern", "raster",
                       "--jpeg", "--gps-sigma", "0.02", "0.03", "--out", str(out)]) == 0
    images = out / "images"
    native.run_tool("mound_recon", ["reconstruct", str(images), "--gps", "exif", "--out",
                                    str(tmp_path / "plain")])
    recon = json.loads((tmp_path / "plain" / "recon.json").read_text())
    assert recon["gps_fit"]["method"].startswith("level")
    assert recon["gps_fit"]["rtk_fixed_images"] == 0
    assert recon["gps_fit"]["latency"]["applied"] is False  # no latency in these photos
    assert recon["gps_fit"]["weighted_by_rtk_std"] is False
    rtk = tmp_path / "rtk"
    rtk.mkdir()
    for p in sorted(images.glob("*.jpg")):
        im = Image.open(p)
        im.save(rtk / p.name, exif=im.info["exif"], xmp=_dji_xmp(100.0, 60.0), quality=95)
    native.run_tool("mound_recon", ["reconstruct", str(rtk), "--gps", "exif", "--out",
                                    str(tmp_path / "rtk_out")])
    recon = json.loads((tmp_path / "rtk_out" / "recon.json").read_text())
    assert recon["gps_fit"]["method"].startswith("full")
    assert recon["gps_fit"]["rtk_fixed_images"] == len(list(rtk.glob("*.jpg")))
    assert recon["gps_fit"]["weighted_by_rtk_std"] is True
    # Issue 67: what the heights are above. EXIF GPS altitude is above sea level (EGM96)
    # without a fix, above the ellipsoid with DJI's RTK fix; recon.json says which.
    assert recon["origin"]["alt_datum"] == "ellipsoid"
    plain = json.loads((tmp_path / "plain" / "recon.json").read_text())
    assert plain["origin"]["alt_datum"] == "egm96"
    # A card mixing the two (one photo without the fix) holds heights tens of metres apart
    # for the same place: refused, naming the counts.
    first = sorted(rtk.glob("*.jpg"))[0]
    im = Image.open(images / first.name)
    im.save(first, exif=im.info["exif"], quality=95)   # its XMP (and fix) gone
    r = subprocess.run([str(build_dir() / "mound_recon"), "reconstruct", str(rtk), "--gps",
                        "exif", "--out", str(tmp_path / "mixed")], capture_output=True,
                       text=True, check=False, timeout=300)
    n = len(list(rtk.glob("*.jpg")))
    assert r.returncode == 2 and r.stderr.count("\n") == 1, r.stderr
    assert f"{n - 1} of {n} photos have a DJI RTK fix" in r.stderr


@pytest.mark.slow
def test_a_card_without_a_plan_gets_sites_from_its_photos(sim_card: dict[str, Any],
                                                          caliterra: Path,
                                                          tmp_path: Path) -> None:
    """Issue 67, a crew that flew by hand: no plan and no sites file. The simulated card's
    two sites (300 m and 500 m from home) are proposed where the plan put them, each with
    every photo the plan gives it and a reach from its photos (not a fixed 60 m); the
    transit frames stay transit. Caliterra's 40 photos make one site holding all of them
    (goal: >= 95 %); its sites.json read back as --sites sorts the card the same way."""
    from mound.geometry.geodesy import Origin, geodetic_to_enu

    out = tmp_path / "sorted"
    doc = sort_card(str(sim_card["dir"] / "card"), None, str(out)).doc
    proposed = json.loads((out / "sites.json").read_text())
    assert proposed["schema"] == "mound.sites" and doc["proposed"]["link_m"] > 0
    plan_origin = Origin(38.5705, 27.9862, 95.0)
    o = Origin.from_doc(proposed["origin"])
    centres = {}
    for s in proposed["sites"]:
        lat, lon = _enu_to_ll(o, s["x_m"], s["y_m"])
        centres[s["id"]] = geodetic_to_enu(plan_origin, np.array([[lat, lon, 0.0]]))[0][:2]
    truth = {f["file"]: f["site"] for f in sim_card["truth"]["files"]}
    got = {r["file"]: r["site"] for r in doc["photos"]}
    assert len(centres) == 2
    for want_id, want_xy in (("a", (300, 0)), ("b", (300, 400))):
        mine = min(centres, key=lambda k: np.hypot(*(centres[k] - np.array(want_xy))))
        assert np.hypot(*(centres[mine] - np.array(want_xy))) < 15, (mine, centres[mine])
        assert {f for f, s in truth.items() if s == want_id} == {
            f for f, s in got.items() if s == mine}
    reach = [s["reach_m"] for s in proposed["sites"]]
    assert all(20 < r < 60 for r in reach), reach
    assert {r["reason"] for r in doc["photos"] if truth[r["file"]] is None} == {"transit"}
    # Caliterra
    cal = sort_card(str(caliterra), None, str(tmp_path / "cal")).doc
    n = len(cal["photos"])
    assert sum(1 for r in cal["photos"] if r["site"]) >= 0.95 * n
    again = sort_card(str(caliterra), str(tmp_path / "cal" / "sites.json"),
                      str(tmp_path / "cal2")).doc
    assert [r["site"] for r in again["photos"]] == [r["site"] for r in cal["photos"]]


def _enu_to_ll(origin: Any, x: float, y: float) -> tuple[float, float]:
    from mound.geometry.geodesy import enu_to_geodetic

    lat, lon, _ = enu_to_geodetic(origin, np.array([[x, y, 0.0]]))[0]
    return float(lat), float(lon)


@pytest.mark.slow
def test_dji_gps_latency_is_estimated_and_every_strip_kept(tmp_path: Path) -> None:
    """Issue 67: DJI's GNSS latency shifts alternate strips of a back-and-forth raster
    along track in opposite directions, and the GPS fit dropped a whole strip (8 of 18
    photos here). A simulated card whose EXIF positions lag the shutter by 0.6 s (one
    photo every 2 s) is fitted with the latency estimated (0.6 s on the 0.05-step grid)
    and every photo kept; the same site without latency applies none."""
    out = tmp_path / "site"
    assert mound_main(["sim", "site", "--size", "320", "240", "--pattern", "raster",
                       "--jpeg", "--gps-sigma", "0.2", "0.3", "--gps-latency", "0.6",
                       "--out", str(out)]) == 0
    native.run_tool("mound_recon", ["reconstruct", str(out / "images"), "--gps", "exif",
                                    "--out", str(tmp_path / "recon")])
    fit = json.loads((tmp_path / "recon" / "recon.json").read_text())["gps_fit"]
    lat = fit["latency"]
    assert lat["applied"] is True and lat["order"] == "EXIF capture time"
    assert lat["seconds"] == pytest.approx(0.6, abs=0.1) and lat["photo_interval_s"] == 2
    assert lat["without"]["inliers"] <= fit["images"] - 6   # a strip lost without it
    assert fit["inliers"] >= fit["images"] - 1 and fit["outliers"] == [
        o["file"] for o in fit["outlier_residuals"]]
    assert mound_main(["sim", "site", "--gps-latency", "0.5", "--out",
                       str(tmp_path / "x")]) == 2  # it moves the EXIF GPS: --jpeg only
    assert not (tmp_path / "x").exists()


@pytest.mark.slow
def test_a_simulated_dji_card_goes_from_photos_to_verdict(tmp_path: Path) -> None:
    """Issue 67: a simulated card carrying what a DJI Phantom 3 writes (make DJI, model
    FC300S, no focal plane resolution, the drone-dji XMP) with DJI's GNSS latency (0.6 s,
    one photo every 2 s) goes through `photos sort` without a plan, `reconstruct --gps
    exif`, `densify` as the survey does and `verdict`: the site proposed from the photos,
    the focal length from the sensor table (exactly the simulator's), the heights stated
    above EGM96, the latency found and every strip kept, and the 12 m tumulus judged
    `mound`."""
    site = tmp_path / "site"
    assert mound_main(["sim", "site", "--size", "640", "480", "--pattern", "raster",
                       "--jpeg", "--exif-style", "dji", "--gps-latency", "0.6",
                       "--out", str(site)]) == 0
    doc = sort_card(str(site / "images"), None, str(tmp_path / "sorted")).doc
    assert list(doc["sites"]) == ["c01"] and doc["sites"]["c01"]["photos"] == 18
    assert doc["sites"]["c01"]["camera"]["source"] == "exif (sensor_table)"
    assert doc["dji_xmp"]["photos"] == 18
    recon, dense = tmp_path / "recon", tmp_path / "dense"
    native.run_tool("mound_recon", ["reconstruct", str(tmp_path / "sorted" / "c01"), "--gps",
                                    "exif", "--out", str(recon), "--threads", "2"])
    native.run_tool("mound_recon", ["densify", str(recon), "--out", str(dense), "--threads",
                                    "2"])
    native.run_tool("mound_recon", ["verdict", str(recon), "--cloud", str(dense / "dense.ply"),
                                    "--out", str(tmp_path / "verdict.json")])
    r = json.loads((recon / "recon.json").read_text())
    true_f = json.loads((site / "camera.json").read_text())["K"][0][0]
    assert r["inputs"]["focal"]["source"] == "sensor_table"
    assert r["inputs"]["focal"]["px"] == pytest.approx(true_f, rel=1e-6)
    assert r["origin"]["alt_datum"] == "egm96" and r["registered"] == 18
    fit = r["gps_fit"]
    assert fit["latency"]["applied"] and fit["latency"]["seconds"] == pytest.approx(0.6, abs=0.1)
    assert fit["inliers"] == 18
    v = json.loads((tmp_path / "verdict.json").read_text())
    assert v["label"] == "mound" and v["cloud"].endswith("dense.ply")


@pytest.mark.slow
def test_the_survey_and_the_standalone_path_give_the_same_verdict(tmp_path: Path) -> None:
    """Issue 67: on a card (simulated DJI, a 2 m x 30 m tumulus, GNSS latency), the survey
    run on the sites the card proposes (`mission.py --sites DIR/sites.json --photos CARD`)
    and the docs' standalone commands with the tools' defaults give the same verdict, p to
    the last bits. 480 x 360 photos: the test runs twice in CI, once under ASan."""
    import sys

    from mound.paths import REPO_ROOT

    site = tmp_path / "site"
    assert mound_main(["sim", "site", "--size", "480", "360", "--pattern", "raster",
                       "--jpeg", "--exif-style", "dji", "--gps-latency", "0.6", "--height",
                       "2", "--diameter", "30", "--out", str(site)]) == 0
    sort_card(str(site / "images"), None, str(tmp_path / "sorted"))
    r = subprocess.run([sys.executable, str(REPO_ROOT / "python" / "mission.py"), "--sites",
                        str(tmp_path / "sorted" / "sites.json"), "--photos",
                        str(site / "images"), "--out", str(tmp_path / "survey")],
                       capture_output=True, text=True, check=False, timeout=900)
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-2000:]
    alone = tmp_path / "alone"
    native.run_tool("mound_recon", ["reconstruct", str(tmp_path / "sorted" / "c01"), "--gps",
                                    "exif", "--out", str(alone), "--threads", "1"])
    native.run_tool("mound_recon", ["densify", str(alone), "--out", str(alone / "dense"),
                                    "--threads", "1"])
    native.run_tool("mound_recon", ["verdict", str(alone), "--cloud",
                                    str(alone / "dense" / "dense.ply"), "--out",
                                    str(alone / "verdict.json")])
    a = json.loads((alone / "verdict.json").read_text())
    s = json.loads((tmp_path / "survey" / "sites" / "c01" / "recon" / "verdict.json")
                   .read_text())
    assert a["label"] == s["label"] == "mound"
    assert a["p_mound"] == pytest.approx(s["p_mound"], abs=1e-12)
