// The scorecard page (scorecard.qmd): filter the rows by paper and status, sort a table by a
// column (click its heading). Plain JavaScript on the tables pkmlib.tools.report writes; without it the
// tables read as they are. No library, no network.
(function () {
  "use strict";
  function text(cell) { return (cell.textContent || "").trim(); }
  function number(s) {
    var m = s.replace(/\u2212/g, "-").replace(/^[±+]/, "").match(/^-?\d+(?:\.\d+)?(?:e[-+]?\d+)?/i);
    return m ? parseFloat(m[0]) : NaN;
  }
  function setup() {
    var tables = Array.prototype.slice.call(document.querySelectorAll("table.scorecard"));
    var box = document.getElementById("scorecard-controls");
    if (!tables.length || !box) return;
    var statuses = {};
    tables.forEach(function (t) {
      t.querySelectorAll("tbody tr").forEach(function (tr) { statuses[tr.dataset.status] = true; });
    });
    function select(label, id, values) {
      var l = document.createElement("label");
      l.textContent = label + " ";
      var s = document.createElement("select");
      s.id = id;
      [["", "all"]].concat(values.map(function (v) { return [v, v]; })).forEach(function (o) {
        var opt = document.createElement("option");
        opt.value = o[0]; opt.textContent = o[1]; s.appendChild(opt);
      });
      l.appendChild(s); box.appendChild(l);
      return s;
    }
    var paper = select("Paper", "scorecard-paper", tables.map(function (t) { return t.dataset.paper; }));
    var status = select("Status", "scorecard-status", Object.keys(statuses).sort());
    var shown = document.createElement("span");
    shown.className = "text-muted small";
    box.appendChild(shown);
    function apply() {
      var n = 0;
      tables.forEach(function (t) {
        var holder = t.closest(".scorecard-holder");
        var section = holder ? holder.closest("section") : null;
        var paperOk = !paper.value || t.dataset.paper === paper.value;
        var any = false;
        t.querySelectorAll("tbody tr").forEach(function (tr) {
          var ok = paperOk && (!status.value || tr.dataset.status === status.value);
          tr.hidden = !ok; if (ok) { n++; any = true; }
        });
        (section || holder || t).hidden = !any;
      });
      shown.textContent = n + " rows shown";
    }
    paper.addEventListener("change", apply);
    status.addEventListener("change", apply);
    tables.forEach(function (t) {
      t.querySelectorAll("th[data-sort]").forEach(function (th) {
        th.tabIndex = 0;
        th.title = "sort by this column";
        function sort() {
          var col = Array.prototype.indexOf.call(th.parentNode.children, th);
          var up = th.getAttribute("aria-sort") !== "ascending";
          t.querySelectorAll("th[aria-sort]").forEach(function (h) { h.removeAttribute("aria-sort"); });
          th.setAttribute("aria-sort", up ? "ascending" : "descending");
          var body = t.tBodies[0];
          var rows = Array.prototype.slice.call(body.rows);
          rows.sort(function (a, b) {
            var x = text(a.cells[col]), y = text(b.cells[col]);
            if (th.dataset.sort === "num") {
              var nx = number(x), ny = number(y);
              if (isNaN(nx) && isNaN(ny)) return 0;
              if (isNaN(nx)) return 1;
              if (isNaN(ny)) return -1;
              return up ? nx - ny : ny - nx;
            }
            return up ? x.localeCompare(y) : y.localeCompare(x);
          });
          rows.forEach(function (r) { body.appendChild(r); });
        }
        th.addEventListener("click", sort);
        th.addEventListener("keydown", function (e) { if (e.key === "Enter") sort(); });
      });
    });
    apply();
  }
  if (document.readyState === "loading") document.addEventListener("DOMContentLoaded", setup);
  else setup();
})();
