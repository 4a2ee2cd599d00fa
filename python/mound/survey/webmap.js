// The survey map (map.html): Leaflet, the data of map/survey.js (window.MOUND_SURVEY), no
// network. After drawing, the page writes what it drew into <body data-*> for the tests:
// markers, paths, overlays (their bounds as Leaflet holds them), errors, ready.
/* global L */
"use strict";

(function () {
  const page = window.MOUND_PAGE;
  const errors = page.errors;
  const D = window.MOUND_SURVEY;
  const body = document.body;
  if (!D || !window.L) {
    errors.push(!D ? "map/survey.js did not load" : "map/leaflet/leaflet.js did not load");
    page.finish();
    return;
  }

  const map = L.map("map", { preferCanvas: false, zoomSnap: 0.25 });
  if (D.basemap) L.tileLayer(D.basemap, { maxZoom: 22 }).addTo(map);

  // p(mound) 0..1 -> a viridis-like ramp.
  const RAMP = ["#440154", "#3b528b", "#21918c", "#5ec962", "#fde725"];
  function colour(p) {
    const t = Math.max(0, Math.min(1, Number(p) || 0)) * (RAMP.length - 1);
    return RAMP[Math.round(t)];
  }
  const VERDICT = { mound: "#ff7f00", no_mound: "#000000", undecided: "#1f78b4", failed: "#e7298a" };
  const FLIGHT = ["#555555", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#bcbd22"];

  function fmt(v) {
    if (typeof v === "number") return Number.isInteger(v) ? String(v) : v.toFixed(3);
    if (typeof v === "boolean") return v ? "yes" : "no";
    if (v === null || v === undefined) return "–";
    return String(v);
  }
  function esc(s) {
    return String(s).replace(/[&<>"]/g, (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;" })[c]);
  }

  const card = document.getElementById("card");
  function showCard(site) {
    const c = site.card;
    const rows = [
      ["p(mound), satellite", c.p_mound], ["reward, bits", c.reward], ["visited", c.visited],
      ["3-D verdict", c.verdict], ["p(mound) after the flight", c.verdict_p_mound],
      ["confidence", c.confidence], ["final label", c.final_label],
      ["label from", c.label_source], ["truth", c.truth], ["second look", c.second_look],
      ["for the field team", c.field_team],
    ];
    for (const [k, v] of Object.entries(c.measurements || {})) rows.push([k, v]);
    if (c.failure) rows.push(["failure", c.failure]);
    let html = `<h2 id="card-title">${esc(site.id)}</h2><table>`;
    for (const [k, v] of rows) {
      if (v === undefined) continue;
      html += `<tr><td>${esc(k)}</td><td class="v" data-key="${esc(k)}">${esc(fmt(v))}</td></tr>`;
    }
    html += "</table>";
    if (c.viewer) html += `<p><a id="viewer-link" href="${esc(c.viewer)}">the site in 3-D</a> (cloud, cameras, ground fit and dome; measure)</p>`;
    const files = Object.entries(c.files || {});
    const pics = files.filter(([, f]) => /\.png$/i.test(f));
    for (const [k, f] of pics) html += `<p><img src="${esc(f)}" alt="${esc(k)}" style="max-width:100%"></p>`;
    if (files.length) {
      html += "<p>Files: " + files.map(([k, f]) => `<a href="${esc(f)}">${esc(k)}</a>`).join(", ") + "</p>";
    }
    card.innerHTML = html;
    card.dataset.site = site.id;
    card.dataset.verdict = c.verdict || "";
  }

  // Overlays first (under the sites).
  const ortho = L.layerGroup(), relief = L.layerGroup(), scene = L.layerGroup();
  const drawn = [];
  for (const o of D.overlays) {
    const layer = L.imageOverlay(o.png, o.bounds, { opacity: o.name === "lrm" ? 0.8 : 1 });
    (o.name === "lrm" ? relief : o.name === "scene_p_mound" ? scene : ortho).addLayer(layer);
    drawn.push({ site: o.site, name: o.name, layer });
  }
  scene.addTo(map);
  ortho.addTo(map);
  const footprints = L.layerGroup();
  for (const ring of D.footprints || []) {
    footprints.addLayer(L.polygon(ring, { color: "#1565c0", weight: 1, fillOpacity: 0.03 }));
  }

  const flights = L.layerGroup();
  const paths = [];
  D.flights.forEach((f, k) => {
    const line = L.polyline(f.path, { color: FLIGHT[k % FLIGHT.length], weight: 2 });
    line.bindTooltip(`flight ${f.flight}${f.cost_m ? `: ${Math.round(f.cost_m)} m` : ""}`);
    flights.addLayer(line);
    paths.push(line);
  });
  flights.addTo(map);
  // The second looks' missions (second_look/): the undecided sites flown again, wider.
  const seconds = L.layerGroup();
  const secondPaths = [];
  (D.second_looks || []).forEach((f) => {
    const line = L.polyline(f.path, { color: "#ef6c00", weight: 2, dashArray: "6 4" });
    line.bindTooltip(`second look, flight ${f.flight}${f.cost_m ? `: ${Math.round(f.cost_m)} m` : ""}`);
    seconds.addLayer(line);
    secondPaths.push(line);
  });
  seconds.addTo(map);
  // A day on cards (mound day): the battery to fly next, planned after the last card.
  const nextBattery = L.layerGroup();
  if (D.next_battery) {
    const nb = D.next_battery;
    nextBattery.addLayer(L.polyline(nb.path, { color: "#00838f", weight: 3, dashArray: "2 6" })
      .bindTooltip(`battery ${nb.battery}, to fly next (battery_${nb.battery}/)`));
    nextBattery.addTo(map);
  }
  // Each mission file as written (every readable format the run wrote), read back: the
  // same path. A style per format, in the order the formats come.
  const STYLE = [["#212121", null], ["#2e7d32", "4 4"], ["#6a1b9a", "1 5"],
    ["#e65100", "6 2"], ["#0277bd", "2 3"], ["#ad1457", "8 3 2 3"]];
  const kinds = [...new Set((D.mission_files || []).map((f) => f.format))];
  const written = L.layerGroup();
  (D.mission_files || []).forEach((f) => {
    const [color, dash] = STYLE[kinds.indexOf(f.format) % STYLE.length];
    written.addLayer(L.polyline(f.path, { color, weight: 1, dashArray: dash })
      .bindTooltip(`${f.file} (${f.waypoints} waypoints), as read back`));
  });

  const sites = L.layerGroup();
  const markers = [];
  for (const s of D.sites) {
    const v = s.card.verdict;
    const m = L.circleMarker([s.lat, s.lon], {
      radius: s.card.visited ? 8 : 6, fillColor: colour(s.card.p_mound), fillOpacity: 0.9,
      color: VERDICT[v] || "#ffffff", weight: v ? 3 : 1,
    });
    m.bindTooltip(`${s.id}: p ${fmt(s.card.p_mound)}${v ? `, verdict ${v}` : ""}`);
    m.on("click", () => showCard(s));
    m.siteId = s.id;
    sites.addLayer(m);
    markers.push(m);
  }
  sites.addTo(map);
  L.marker([D.home.lat, D.home.lon], { title: "home" }).bindTooltip("home").addTo(map);

  const layers = {
    "sites (p(mound))": sites, "flights": flights, "image footprints": footprints,
    "orthophotos": ortho, "relief models (LRM)": relief,
  };
  if (D.overlays.some((o) => o.name === "scene_p_mound")) layers["scene p(mound)"] = scene;
  if (secondPaths.length) layers["second looks"] = seconds;
  if (D.next_battery) layers["next battery"] = nextBattery;
  if (kinds.length) layers[`mission files (${kinds.map((k) => `.${k}`).join(", ")})`] = written;
  L.control.layers(null, layers, { collapsed: false }).addTo(map);
  L.control.scale({ metric: true, imperial: false }).addTo(map);
  const legend = L.control({ position: "bottomleft" });
  legend.onAdd = () => {
    const div = L.DomUtil.create("div", "legend");
    let html = "<b>p(mound)</b><br>";
    RAMP.forEach((c, i) => { html += `<i style="background:${c}"></i>${(i / (RAMP.length - 1)).toFixed(2)} `; });
    html += "<br><b>3-D verdict</b> (ring)<br>";
    for (const [k, c] of Object.entries(VERDICT)) html += `<i style="background:${c}"></i>${k} `;
    div.innerHTML = html;
    return div;
  };
  legend.addTo(map);

  const all = D.sites.map((s) => [s.lat, s.lon]).concat([[D.home.lat, D.home.lon]]);
  map.fitBounds(L.latLngBounds(all).pad(0.05));

  // What was drawn, for the tests.
  body.dataset.markers = String(markers.length);
  body.dataset.paths = String(paths.length);
  body.dataset.secondLooks = String(secondPaths.length);
  body.dataset.nextBattery = D.next_battery ? String(D.next_battery.battery) : "";
  body.dataset.footprints = String((D.footprints || []).length);
  body.dataset.missionFiles = JSON.stringify(written.getLayers().map((l) => l.getLatLngs().length));
  body.dataset.overlays = JSON.stringify(drawn.map((d) => {
    const b = d.layer.getBounds();
    return { site: d.site, name: d.name, bounds: [[b.getSouth(), b.getWest()], [b.getNorth(), b.getEast()]] };
  }));
  if (location.hash === "#selftest") {
    // Click the first visited site's marker as a user would (a DOM click on its path).
    const first = markers.find((m) => D.sites.find((s) => s.id === m.siteId).card.visited);
    if (first) {
      const el = first.getElement ? first.getElement() : first._path;
      el.dispatchEvent(new MouseEvent("click", { bubbles: true, cancelable: true }));
      body.dataset.cardSite = card.dataset.site || "";
      body.dataset.cardVerdict = card.dataset.verdict || "";
    }
    // Green when the page drew what its data holds without error (pagecheck.js).
    const ok = errors.length === 0 && markers.length === D.sites.length &&
      paths.length === D.flights.length &&
      secondPaths.length === (D.second_looks || []).length &&
      (!first || card.dataset.site === first.siteId);
    page.banner(ok);
  }
  page.finish();
})();
