// One site in 3-D (site3d.html#ID): the cloud of map/sites/ID.js (window.MOUND_SITE) with
// three.js, the cameras' frustums, the ground fit and the judged rise as a dome; turn, pan,
// zoom; colour by RGB or by height above the ground fit; a measuring tool (two clicks: the
// distance between the picked points, and each one's height above the ground fit).
// Frame: metres, x east and y north of the site centre, z up from the ground fit's height
// at the centre. After drawing, the page writes into <body data-*> what the tests read:
// points, nonblank (canvas pixels not background), errors, ready; with #ID/selftest and a
// test_pick pair in the data it clicks those two points and writes measured.
/* global THREE */
"use strict";

(function () {
  const body = document.body;
  const page = window.MOUND_PAGE;
  const errors = page.errors;
  const finish = page.finish;

  const [siteId, mode] = decodeURIComponent(location.hash.slice(1)).split("/");
  if (!siteId || !/^[A-Za-z0-9_-][A-Za-z0-9_.-]*$/.test(siteId)) {
    errors.push("no site in the address (site3d.html#SITE_ID)");
    finish();
    return;
  }
  const script = document.createElement("script");
  script.src = `map/sites/${siteId}.js`;
  script.onerror = () => { errors.push(`map/sites/${siteId}.js did not load`); finish(); };
  script.onload = () => {
    try {
      draw(window.MOUND_SITE, mode === "selftest");
    } catch (e) {
      errors.push(String(e && e.stack || e));
    }
    finish();
  };
  document.head.appendChild(script);

  function decode(b64, Type) {
    const bin = atob(b64);
    const bytes = new Uint8Array(bin.length);
    for (let i = 0; i < bin.length; ++i) bytes[i] = bin.charCodeAt(i);
    return new Type(bytes.buffer);
  }

  function draw(D, selftest) {
    document.getElementById("title").textContent = `Site ${D.site}`;
    document.getElementById("note").textContent =
      `${D.points.toLocaleString()} of ${D.points_in_cloud.toLocaleString()} points shown (${D.note})`;
    const g = D.ground;
    const groundZ = (x, y) => g[0] + g[1] * x + g[2] * y + g[3] * x * x + g[4] * x * y + g[5] * y * y;

    const view = document.getElementById("view");
    let renderer;
    try {
      renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
    } catch (e) {
      document.getElementById("note").textContent =
        "This browser gives the page no WebGL, which the 3-D view needs (the map works without it).";
      throw e;
    }
    renderer.setPixelRatio(1);
    renderer.setSize(view.clientWidth, view.clientHeight);
    renderer.setClearColor(0xf4f4f4);
    view.appendChild(renderer.domElement);
    const scene = new THREE.Scene();
    const R = Math.max(D.radius_m, 5);
    const camera = new THREE.PerspectiveCamera(50, view.clientWidth / view.clientHeight, R / 200, R * 50);
    camera.up.set(0, 0, 1);

    // The cloud: positions, RGB colours, and colours by height above the ground fit.
    const pos = decode(D.positions, Float32Array);
    const rgb = decode(D.colours, Uint8Array);
    const n = D.points;
    const colRgb = new Float32Array(3 * n), colHeight = new Float32Array(3 * n);
    let hmax = 0.5;
    const above = new Float32Array(n);
    for (let i = 0; i < n; ++i) {
      above[i] = pos[3 * i + 2] - groundZ(pos[3 * i], pos[3 * i + 1]);
      hmax = Math.max(hmax, Math.abs(above[i]));
    }
    hmax = Math.min(hmax, 20);
    for (let i = 0; i < n; ++i) {
      for (let k = 0; k < 3; ++k) colRgb[3 * i + k] = rgb[3 * i + k] / 255;
      const t = Math.max(-1, Math.min(1, above[i] / hmax));  // blue - white - red
      colHeight[3 * i] = t > 0 ? 1 : 1 + t;
      colHeight[3 * i + 1] = 1 - Math.abs(t);
      colHeight[3 * i + 2] = t < 0 ? 1 : 1 - t;
    }
    const geom = new THREE.BufferGeometry();
    geom.setAttribute("position", new THREE.BufferAttribute(pos, 3));
    const colour = new THREE.BufferAttribute(colRgb, 3);
    geom.setAttribute("color", colour);
    const cloud = new THREE.Points(geom, new THREE.PointsMaterial({ size: 2, sizeAttenuation: false, vertexColors: true }));
    scene.add(cloud);

    // The ground fit over the site (a wire grid) and the rise as a paraboloid dome on its own
    // ground plane (verdict.json's rise.ground_plane; the site's ground fit without one).
    const lines = [];
    const N = 20;
    for (let a = 0; a <= N; ++a) {
      const rowX = [], rowY = [];
      for (let b = 0; b <= N; ++b) {
        const u = -R + (2 * R * a) / N, v = -R + (2 * R * b) / N;
        rowX.push(new THREE.Vector3(u, v, groundZ(u, v)));
        rowY.push(new THREE.Vector3(v, u, groundZ(v, u)));
      }
      lines.push(rowX, rowY);
    }
    const groundMat = new THREE.LineBasicMaterial({ color: 0x2e7d32, transparent: true, opacity: 0.35 });
    const groundGroup = new THREE.Group();
    for (const l of lines) groundGroup.add(new THREE.Line(new THREE.BufferGeometry().setFromPoints(l), groundMat));
    scene.add(groundGroup);
    if (D.rise) {
      const { x, y, height_m: h, base_diameter_m: d, plane, curvature } = D.rise;
      // the dome on the rise's own ground where verdict.json gives it: a plane, or a
      // quadratic for a rise measured over a curved ground
      const c = curvature || [0, 0, 0];
      const baseZ = plane
        ? (u, v) => plane[0] + plane[1] * (u - x) + plane[2] * (v - y) +
            c[0] * (u - x) * (u - x) + c[1] * (u - x) * (v - y) + c[2] * (v - y) * (v - y)
        : groundZ;
      const domeMat = new THREE.LineBasicMaterial({ color: 0xff6f00 });
      for (let k = 0; k < 12; ++k) {  // meridians
        const a = (2 * Math.PI * k) / 12, pts = [];
        for (let j = 0; j <= 16; ++j) {
          const r = (d / 2) * (j / 16);
          const u = x + r * Math.cos(a), v = y + r * Math.sin(a);
          pts.push(new THREE.Vector3(u, v, baseZ(u, v) + h * (1 - (4 * r * r) / (d * d))));
        }
        scene.add(new THREE.Line(new THREE.BufferGeometry().setFromPoints(pts), domeMat));
      }
    }
    // The cameras: a frustum per registered image.
    const camMat = new THREE.LineBasicMaterial({ color: 0xc62828 });
    for (const c of D.cameras) {
      const C = new THREE.Vector3(...c.centre);
      const k = c.corners.map((p) => new THREE.Vector3(...p));
      const pts = [C, k[0], C, k[1], C, k[2], C, k[3], k[0], k[1], k[1], k[2], k[2], k[3], k[3], k[0]];
      scene.add(new THREE.LineSegments(new THREE.BufferGeometry().setFromPoints(pts), camMat));
    }

    // Orbit controls: turn about the target, pan, zoom.
    const target = new THREE.Vector3(0, 0, 0);
    let radius = 2.2 * R, theta = -Math.PI / 2, phi = 0.9;  // phi from the zenith
    function place() {
      camera.position.set(
        target.x + radius * Math.sin(phi) * Math.cos(theta),
        target.y + radius * Math.sin(phi) * Math.sin(theta),
        target.z + radius * Math.cos(phi));
      camera.lookAt(target);
      camera.updateMatrixWorld();
    }
    function render() { renderer.render(scene, camera); }
    function reset() { target.set(0, 0, 0); radius = 2.2 * R; theta = -Math.PI / 2; phi = 0.9; place(); render(); }
    place();
    const canvas = renderer.domElement;
    let drag = null;
    canvas.addEventListener("contextmenu", (e) => e.preventDefault());
    canvas.addEventListener("pointerdown", (e) => {
      drag = { x: e.clientX, y: e.clientY, x0: e.clientX, y0: e.clientY, pan: e.shiftKey || e.button === 2 };
    });
    canvas.addEventListener("pointermove", (e) => {
      if (!drag) return;
      const dx = e.clientX - drag.x, dy = e.clientY - drag.y;
      drag.x = e.clientX; drag.y = e.clientY;
      if (drag.pan) {
        const s = (radius * 1.5) / canvas.clientHeight;
        const right = new THREE.Vector3().setFromMatrixColumn(camera.matrixWorld, 0);
        const up = new THREE.Vector3().setFromMatrixColumn(camera.matrixWorld, 1);
        target.addScaledVector(right, -dx * s).addScaledVector(up, dy * s);
      } else {
        theta -= dx * 0.008;
        phi = Math.max(0.05, Math.min(Math.PI / 2 - 0.02, phi - dy * 0.008));
      }
      place();
      render();
    });
    canvas.addEventListener("pointerup", (e) => {
      const click = drag && Math.hypot(e.clientX - drag.x0, e.clientY - drag.y0) < 4;
      drag = null;
      if (click && measuring) pick(e.clientX, e.clientY);
    });
    canvas.addEventListener("wheel", (e) => {
      e.preventDefault();
      radius = Math.max(R / 50, Math.min(R * 20, radius * Math.exp(e.deltaY * 0.001)));
      place();
      render();
    }, { passive: false });

    // Colour by RGB or by height.
    const colourButton = document.getElementById("colour");
    let byHeight = false;
    colourButton.addEventListener("click", () => {
      byHeight = !byHeight;
      colour.array.set(byHeight ? colHeight : colRgb);
      colour.needsUpdate = true;
      colourButton.textContent = `colour: ${byHeight ? `height (±${hmax.toFixed(1)} m)` : "RGB"}`;
      render();
    });
    document.getElementById("reset").addEventListener("click", reset);

    // Measuring: the point nearest the click (within 6 px on screen), two of them.
    let measuring = false;
    const picked = [];
    const marks = new THREE.Group();
    scene.add(marks);
    const out = document.getElementById("measure-out");
    const measureButton = document.getElementById("measure");
    measureButton.addEventListener("click", () => {
      measuring = !measuring;
      measureButton.textContent = measuring ? "measuring: click two points" : "measure";
      picked.length = 0;
      marks.clear();
      out.textContent = "";
      render();
    });
    const ray = new THREE.Raycaster();
    function pick(clientX, clientY) {
      const rect = canvas.getBoundingClientRect();
      const ndc = new THREE.Vector2(((clientX - rect.left) / rect.width) * 2 - 1,
        -((clientY - rect.top) / rect.height) * 2 + 1);
      ray.setFromCamera(ndc, camera);
      // 6 px at the target's distance, in metres.
      const px = (2 * Math.tan((camera.fov * Math.PI) / 360) * camera.position.distanceTo(target)) / rect.height;
      ray.params.Points.threshold = 6 * px;
      const hits = ray.intersectObject(cloud);
      if (!hits.length) return;
      hits.sort((a, b) => a.distanceToRay - b.distanceToRay || a.distance - b.distance);
      const i = hits[0].index;
      const p = new THREE.Vector3(pos[3 * i], pos[3 * i + 1], pos[3 * i + 2]);
      if (picked.length === 2) { picked.length = 0; marks.clear(); }
      picked.push({ p, above: above[i] });
      const dot = new THREE.Mesh(new THREE.SphereGeometry(R / 150, 8, 8), new THREE.MeshBasicMaterial({ color: 0x0d47a1 }));
      dot.position.copy(p);
      marks.add(dot);
      if (picked.length === 2) {
        const [a, b] = picked;
        marks.add(new THREE.Line(new THREE.BufferGeometry().setFromPoints([a.p, b.p]), new THREE.LineBasicMaterial({ color: 0x0d47a1 })));
        const d = a.p.distanceTo(b.p);
        out.textContent = `distance ${d.toFixed(2)} m (horizontal ${Math.hypot(a.p.x - b.p.x, a.p.y - b.p.y).toFixed(2)} m); heights above the ground fit ${a.above.toFixed(2)} m, ${b.above.toFixed(2)} m`;
        out.dataset.distance = String(d);
      } else {
        out.textContent = `height above the ground fit ${picked[0].above.toFixed(2)} m`;
      }
      out.dataset.above = String(picked[picked.length - 1].above);
      render();
    }

    window.addEventListener("resize", () => {
      renderer.setSize(view.clientWidth, view.clientHeight);
      camera.aspect = view.clientWidth / view.clientHeight;
      camera.updateProjectionMatrix();
      render();
    });
    render();

    // What was drawn, for the tests.
    const gl = renderer.getContext();
    const w = gl.drawingBufferWidth, h = gl.drawingBufferHeight;
    const px = new Uint8Array(4 * w * h);
    gl.readPixels(0, 0, w, h, gl.RGBA, gl.UNSIGNED_BYTE, px);
    let nonblank = 0;
    for (let i = 0; i < px.length; i += 4) nonblank += (px[i] !== 0xf4 || px[i + 1] !== 0xf4 || px[i + 2] !== 0xf4) ? 1 : 0;
    body.dataset.points = String(n);
    body.dataset.nonblank = String(nonblank);
    if (selftest && D.test_pick) {
      // Click the two test points where the camera shows them, as a user would.
      measureButton.click();
      for (const i of D.test_pick) {
        const v = new THREE.Vector3(pos[3 * i], pos[3 * i + 1], pos[3 * i + 2]).project(camera);
        const rect = canvas.getBoundingClientRect();
        const x = rect.left + ((v.x + 1) / 2) * rect.width, y = rect.top + ((1 - v.y) / 2) * rect.height;
        const opts = { bubbles: true, clientX: x, clientY: y, button: 0 };
        canvas.dispatchEvent(new PointerEvent("pointerdown", opts));
        canvas.dispatchEvent(new PointerEvent("pointerup", opts));
      }
      body.dataset.measured = out.dataset.distance || "";
      body.dataset.above = out.dataset.above || "";
      // Green when the measurement matches the data's expected distance to 1 % (pagecheck.js).
      const d = Number(out.dataset.distance);
      page.banner(errors.length === 0 && nonblank > 10000 && D.test_expect_m > 0 &&
        Math.abs(d - D.test_expect_m) < 0.01 * D.test_expect_m);
    }
  }
})();
