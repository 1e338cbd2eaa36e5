// Each figure of a notebook page links the cell that made it: the cell gets an id (cell-<n>, in
// page order) and the figure's caption ends with "made by this cell's code", which opens the
// folded code and scrolls to it. Plain JavaScript, no library.
(function () {
  "use strict";
  function setup() {
    var cells = document.querySelectorAll("main div.cell");
    var n = 0;
    cells.forEach(function (cell) {
      n += 1;
      var figures = cell.querySelectorAll("figure figcaption");
      var code = cell.querySelector("details.code-fold, div.sourceCode, pre.sourceCode");
      if (!figures.length || !code) return;
      if (!cell.id) cell.id = "cell-" + n;
      figures.forEach(function (cap) {
        if (cap.querySelector("a.figure-cell")) return;
        var a = document.createElement("a");
        a.className = "figure-cell";
        a.href = "#" + cell.id;
        a.textContent = "made by this cell's code";
        a.addEventListener("click", function () {
          var d = cell.querySelector("details.code-fold");
          if (d) d.open = true;
        });
        cap.appendChild(document.createTextNode(" ("));
        cap.appendChild(a);
        cap.appendChild(document.createTextNode(")"));
      });
    });
  }
  if (document.readyState === "loading") document.addEventListener("DOMContentLoaded", setup);
  else setup();
})();
