"""GeoTIFF rasters of a site (mound.recon.rasters), read back with rasterio; the UTM
coordinates of the test points come from PROJ (pyproj) independently of the module."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import rasterio
from pyproj import Transformer

from mound.cli import main as mound_main
from mound.errors import InputError
from mound.geometry.geodesy import Origin, enu_to_geodetic
from mound.ply import write_ply
from mound.recon import rasters

ORIGIN = Origin(38.5705, 27.9862, 95.0)  # Bin Tepe: UTM zone 35 north
MOUND = (10.0, -5.0, 3.0, 20.0)          # centre east, north, height, radius (m)


def mound_cloud(step: float = 0.5, half: float = 60.0, seed: int = 0) -> np.ndarray:
    """A plane tilted 1 % to the east with a 3 m conical mound, points jittered on a grid."""
    rng = np.random.default_rng(seed)
    g = np.arange(-half, half, step)
    e, n = np.meshgrid(g, g)
    e = e.ravel() + rng.uniform(0, step, e.size)
    n = n.ravel() + rng.uniform(0, step, n.size)
    ce, cn, h, r = MOUND
    z = 0.01 * e + h * np.clip(1 - np.hypot(e - ce, n - cn) / r, 0, None)
    return np.stack([e, n, z], axis=1)


def utm(enu: np.ndarray) -> np.ndarray:
    llh = enu_to_geodetic(ORIGIN, enu)
    e, n = Transformer.from_crs("EPSG:4326", "EPSG:32635", always_xy=True).transform(
        llh[:, 1], llh[:, 0])
    return np.stack([e, n, llh[:, 2]], axis=1)


def recon_dir(tmp_path: Path, cloud: np.ndarray, **doc: object) -> Path:
    d = tmp_path / "recon"
    d.mkdir()
    base = {"schema": "mound.recon", "version": 1, "status": "ok", "frame": "enu",
            "scale": "metric", "origin": ORIGIN.to_doc(), "images": [], "points": len(cloud)}
    (d / "recon.json").write_text(json.dumps({**base, **doc}))
    write_ply(d / "points.ply", cloud)
    return d


def test_utm_zone_of_the_origin() -> None:
    assert rasters.utm_epsg(ORIGIN.lat_deg, ORIGIN.lon_deg) == 32635
    assert rasters.utm_epsg(-33.9, 18.4) == 32734  # Cape Town: zone 34 south
    assert rasters.utm_epsg(0.0, 179.99) == 32660
    with pytest.raises(InputError, match="UTM"):
        rasters.utm_epsg(85.0, 0.0)


def test_rasters_have_crs_transform_size_and_the_mound(tmp_path: Path) -> None:
    cloud = mound_cloud()
    d = recon_dir(tmp_path, cloud)
    out = tmp_path / "rasters"
    assert mound_main(["recon", "rasters", str(d), "--out", str(out),
                       "--resolution-m", "1"]) == 0
    doc = json.loads((out / "rasters.json").read_text())
    assert doc["schema"] == "mound.rasters" and doc["crs"] == "EPSG:32635"
    corners = utm(cloud)
    for name in ("dsm", "dtm", "lrm", "hillshade"):
        with rasterio.open(out / f"{name}.tif") as ds:
            assert ds.crs.to_epsg() == 32635
            assert ds.res == (1.0, 1.0) and ds.nodata == rasters.NODATA
            assert (ds.width, ds.height) == (doc["width"], doc["height"])
            # the raster covers the cloud and no more than a cell beyond it
            b = ds.bounds
            assert b.left <= corners[:, 0].min() < b.left + 1
            assert b.top - 1 < corners[:, 1].max() <= b.top
            assert b.right - 1 <= corners[:, 0].max() < b.right + 1
    with rasterio.open(out / "dsm.tif") as ds:
        dsm = ds.read(1)
        top = utm(np.array([[MOUND[0], MOUND[1], MOUND[2]]]))[0]
        row, col = ds.index(top[0], top[1])
        far = utm(np.array([[-50.0, 50.0, -0.5]]))[0]
        frow, fcol = ds.index(far[0], far[1])
    with rasterio.open(out / "lrm.tif") as ds:
        lrm = ds.read(1)
    with rasterio.open(out / "dtm.tif") as ds:
        dtm = ds.read(1)
    # The DSM at the mound's top cell: the apex height (ellipsoidal: origin 95 m + 0.1 m of
    # tilt + 3 m), within what 1 m cells of a 3 m / 20 m cone allow.
    assert dsm[row, col] == pytest.approx(top[2], abs=0.2)
    assert dsm[frow, fcol] == pytest.approx(far[2], abs=0.1)
    # The ground model runs under the mound (the filter keeps the lowest flank, < 0.8 m of
    # this cone, as ground, so up to a third of the height remains); the relief model shows
    # the mound alone.
    assert ORIGIN.alt_m < dtm[row, col] < ORIGIN.alt_m + 0.1 + 1.0
    assert lrm[row, col] == pytest.approx(3.0, abs=0.4)
    assert abs(lrm[frow, fcol]) < 0.3
    assert doc["coverage"] > 0.95


def test_a_point_lands_in_its_cell(tmp_path: Path) -> None:
    """A spike at a known ENU position is the DSM maximum of the cell PROJ puts it in."""
    cloud = mound_cloud(step=1.0, half=30.0)
    spike = np.array([[-12.3, 7.9, 25.0]])
    r = rasters.from_cloud(ORIGIN, np.vstack([cloud, spike]), resolution_m=0.5,
                           ground_window_m=20)
    out = tmp_path / "r"
    rasters.write_all(r, out)
    e, n, h = utm(spike)[0]
    with rasterio.open(out / "dsm.tif") as ds:
        row, col = ds.index(e, n)
        dsm = ds.read(1)
        assert dsm[row, col] == pytest.approx(h, abs=1e-3)
        assert np.nanmax(np.where(dsm == rasters.NODATA, np.nan, dsm)) == pytest.approx(h,
                                                                                         abs=1e-3)
        # cell centre within half a cell of the point
        x, y = ds.xy(row, col)
        assert abs(x - e) <= 0.25 + 1e-9 and abs(y - n) <= 0.25 + 1e-9


def test_bad_reconstructions_and_clouds_are_refused(tmp_path: Path,
                                                    capsys: pytest.CaptureFixture) -> None:
    cloud = mound_cloud(step=2.0, half=10.0)
    unscaled = recon_dir(tmp_path, cloud, frame="arbitrary", scale="unknown")
    assert mound_main(["recon", "rasters", str(unscaled), "--out", str(tmp_path / "a")]) == 2
    assert "metric ENU" in capsys.readouterr().err
    (tmp_path / "recon").rename(tmp_path / "recon_unscaled")
    failed = recon_dir(tmp_path, cloud, status="failed", reason="no motion")
    assert mound_main(["recon", "rasters", str(failed), "--out", str(tmp_path / "b")]) == 2
    assert "no motion" in capsys.readouterr().err
    (tmp_path / "recon").rename(tmp_path / "recon_failed")
    empty = recon_dir(tmp_path, np.zeros((0, 3)))
    assert mound_main(["recon", "rasters", str(empty), "--out", str(tmp_path / "c")]) == 2
    assert "empty" in capsys.readouterr().err
    (tmp_path / "recon").rename(tmp_path / "recon_empty")
    ok = recon_dir(tmp_path, cloud)
    for args in (["--resolution-m", "0"], ["--resolution-m", "nan"],
                 ["--ground-window-m", "-1"], ["--relief-sigma-m", "0"]):
        assert mound_main(["recon", "rasters", str(ok), "--out", str(tmp_path / "d"),
                           *args]) == 2
        assert args[0] in capsys.readouterr().err
    for name in "abcd":  # nothing written for a refused input
        assert not list((tmp_path / name).glob("*.tif"))


def test_the_rasters_say_what_their_heights_are_above(tmp_path: Path) -> None:
    """Issue 67: a model georeferenced from the photos' EXIF GPS altitude (above sea
    level, EGM96) gives rasters whose CRS is compound, UTM + EGM96 height, and whose bands
    say so; an ellipsoidal origin (a poses file, DJI's RTK fix) keeps the UTM CRS and says
    "ellipsoid"; an old recon.json without the datum is read by its gps_source and says
    so; an unknown datum is refused."""
    from pyproj import CRS

    cloud = mound_cloud()
    for k, (origin_extra, inputs, want) in enumerate((
            ({"alt_datum": "egm96"}, {}, "egm96"),
            ({"alt_datum": "ellipsoid"}, {}, "ellipsoid"),
            ({}, {"gps_source": "exif"}, "egm96"))):
        sub = tmp_path / str(k)
        sub.mkdir()
        d = recon_dir(sub, cloud, origin={**ORIGIN.to_doc(), **origin_extra}, inputs=inputs)
        out = sub / "rasters"
        assert mound_main(["recon", "rasters", str(d), "--out", str(out), "--resolution-m",
                           "1", "--no-orthophoto"]) == 0
        doc = json.loads((out / "rasters.json").read_text())
        assert doc["vertical_datum"] == want and doc["crs"] == "EPSG:32635"
        assert ("vertical_datum_note" in doc) == (not origin_extra)
        with rasterio.open(out / "dsm.tif") as ds:
            crs = CRS.from_wkt(ds.crs.to_wkt())
            words = ds.descriptions[0]
        if want == "egm96":
            assert crs.is_compound and [c.to_epsg() for c in crs.sub_crs_list] == [32635, 5773]
            assert doc["file_crs"] == "EPSG:32635+5773" and "EGM96 geoid" in words
        else:
            assert crs.to_epsg() == 32635 and "WGS84 ellipsoid" in words
    d = recon_dir(tmp_path / "bad" if (tmp_path / "bad").mkdir() is None else tmp_path,
                  cloud, origin={**ORIGIN.to_doc(), "alt_datum": "navd88"})
    with pytest.raises(InputError, match="alt_datum"):
        rasters.from_recon(d, tmp_path / "bad_out")
