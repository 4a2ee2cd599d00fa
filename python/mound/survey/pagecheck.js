// What both report pages (map.html, site3d.html) share for the tests: the errors seen
// (window errors and console.error, from before the other scripts load), finish() writing
// them and data-ready into <body>, and banner(ok): a green square when the page's own check
// passed, else a red one, for browsers the tests can only photograph (Firefox's
// --screenshot). Loaded first, as a classic script.
"use strict";

window.MOUND_PAGE = (function () {
  const errors = [];
  window.addEventListener("error", (e) => errors.push(String(e.message || e)));
  const consoleError = console.error.bind(console);
  console.error = (...a) => { errors.push(a.map(String).join(" ")); consoleError(...a); };
  return {
    errors,
    finish() {
      document.body.dataset.errors = JSON.stringify(errors);
      document.body.dataset.ready = "1";
    },
    banner(ok) {
      const div = document.createElement("div");
      div.id = "selftest";
      div.style.cssText = "position:fixed;top:0;left:0;width:120px;height:120px;z-index:10000;" +
        `background:${ok ? "#00ff00" : "#ff0000"}`;
      document.body.appendChild(div);
    },
  };
})();
