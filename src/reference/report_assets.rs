//! The report page's style sheet and scripts, inlined into every page so that it needs no
//! network and no other file than its images.

/// The style sheet.
pub const STYLE: &str = r#"
body { font: 14px/1.4 system-ui, sans-serif; margin: 1.5em; background: #fafafa; color: #222; }
h1 { font-size: 1.5em; } h2 { font-size: 1.2em; margin-top: 1.6em; }
table { border-collapse: collapse; margin: 0.6em 0; }
th, td { border: 1px solid #ccc; padding: 2px 8px; text-align: right; }
th:first-child, td:first-child { text-align: left; }
th { background: #eee; }
.grid { display: flex; flex-wrap: wrap; gap: 10px; align-items: flex-start; }
figure { margin: 0; }
figcaption { font-size: 12px; color: #444; max-width: 420px; }
.view { overflow: hidden; position: relative; cursor: grab; background: #000; touch-action: none; }
.view img { display: block; transform-origin: 0 0; image-rendering: pixelated; user-select: none; -webkit-user-drag: none; }
.crop { image-rendering: pixelated; display: block; }
.note { color: #555; max-width: 60em; }
#status[data-status=ok] { color: #070; } #status[data-status=error] { color: #b00; font-weight: bold; }
"#;

/// Runs first (in the head): records script errors, failed resources and console errors, so
/// that the page can say whether it loaded cleanly.
pub const HEAD_SCRIPT: &str = r#"
window.reportErrors = [];
window.addEventListener('error', function (e) {
  var t = e.target;
  window.reportErrors.push(t && t !== window && (t.src || t.href)
    ? 'failed to load ' + (t.src || t.href) : String(e.message));
}, true);
(function () {
  var original = console.error;
  console.error = function () {
    window.reportErrors.push(Array.prototype.join.call(arguments, ' '));
    return original.apply(console, arguments);
  };
})();
"#;

/// Runs at the end of the body: synchronized zoom (wheel, around the cursor) and pan (drag) of
/// every `.view`, reset on double-click; and, once everything loaded, the status line
/// (`#status`, `data-status` ok or error) checking that every image decoded.
pub const BODY_SCRIPT: &str = r#"
(function () {
  var views = Array.prototype.slice.call(document.querySelectorAll('.view'));
  var s = 1, tx = 0, ty = 0, drag = null;
  var zoom = document.getElementById('zoom');
  function clamp(v) {
    var w = v.clientWidth, h = v.clientHeight;
    tx = Math.min(0, Math.max(w - w * s, tx));
    ty = Math.min(0, Math.max(h - h * s, ty));
  }
  function apply() {
    if (views.length) clamp(views[0]);
    views.forEach(function (v) {
      v.firstElementChild.style.transform =
        'translate(' + tx + 'px,' + ty + 'px) scale(' + s + ')';
    });
    if (zoom) zoom.textContent = s.toFixed(2) + 'x';
  }
  views.forEach(function (v) {
    v.addEventListener('wheel', function (e) {
      e.preventDefault();
      var r = v.getBoundingClientRect();
      var mx = e.clientX - r.left, my = e.clientY - r.top;
      var ns = Math.min(64, Math.max(1, s * (e.deltaY < 0 ? 1.25 : 0.8)));
      tx = mx - (mx - tx) * ns / s;
      ty = my - (my - ty) * ns / s;
      s = ns;
      apply();
    }, { passive: false });
    v.addEventListener('pointerdown', function (e) {
      drag = { x: e.clientX, y: e.clientY, tx: tx, ty: ty };
      v.setPointerCapture(e.pointerId);
    });
    v.addEventListener('pointermove', function (e) {
      if (!drag) return;
      tx = drag.tx + e.clientX - drag.x;
      ty = drag.ty + e.clientY - drag.y;
      apply();
    });
    v.addEventListener('pointerup', function () { drag = null; });
    v.addEventListener('dblclick', function () { s = 1; tx = 0; ty = 0; apply(); });
  });
  apply();
  window.addEventListener('load', function () {
    var images = Array.prototype.slice.call(document.images);
    var bad = images.filter(function (i) { return !(i.complete && i.naturalWidth > 0); })
      .map(function (i) { return 'image not loaded: ' + i.getAttribute('src'); });
    var problems = bad.concat(window.reportErrors);
    var status = document.getElementById('status');
    if (problems.length) {
      status.dataset.status = 'error';
      status.textContent = 'Errors: ' + problems.join('; ');
    } else {
      status.dataset.status = 'ok';
      status.textContent = 'All ' + images.length + ' images loaded.';
    }
  });
})();
"#;
