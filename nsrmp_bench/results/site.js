// Sortable leaderboard tables (nsrmp-bench). No dependencies, works from file://.
// Click a column heading to sort by it (numbers by their data-value); click again to
// reverse. The heading carries aria-sort; empty values always sort last. Boxes in a
// fieldset.filters hide the rows of a protocol or the reference rows.
(function () {
  "use strict";
  function key(cell) {
    var v = cell.getAttribute("data-value");
    if (v === null) { return { num: false, text: cell.textContent.trim().toLowerCase() }; }
    if (v === "") { return { num: true, missing: true }; }
    return { num: true, value: parseFloat(v) };
  }
  function compare(a, b, dir) {
    if (a.num && b.num) {
      if (a.missing || b.missing) { return (a.missing ? 1 : 0) - (b.missing ? 1 : 0); }
      return dir * (a.value - b.value);
    }
    return dir * (a.text < b.text ? -1 : a.text > b.text ? 1 : 0);
  }
  function sortBy(table, index, th) {
    var body = table.tBodies[0];
    var rows = Array.prototype.slice.call(body.rows);
    var dir = th.getAttribute("aria-sort") === "descending" ? 1 : -1;
    if (th.getAttribute("data-type") === "text" && !th.hasAttribute("aria-sort")) { dir = 1; }
    rows = rows.map(function (row, i) { return { row: row, i: i, k: key(row.cells[index]) }; });
    rows.sort(function (a, b) { return compare(a.k, b.k, dir) || a.i - b.i; });
    rows.forEach(function (r) { body.appendChild(r.row); });
    Array.prototype.forEach.call(table.tHead.rows[0].cells, function (h) {
      h.removeAttribute("aria-sort");
    });
    th.setAttribute("aria-sort", dir === 1 ? "ascending" : "descending");
  }
  document.querySelectorAll("table.sortable").forEach(function (table) {
    Array.prototype.forEach.call(table.tHead.rows[0].cells, function (th, index) {
      if (th.getAttribute("data-type") === "none") { return; }
      var button = document.createElement("button");
      button.type = "button";
      button.textContent = th.textContent;
      th.textContent = "";
      th.appendChild(button);
      button.addEventListener("click", function () { sortBy(table, index, th); });
    });
  });
  // Filters: a row shows when its protocol's box is ticked; a reference row (class
  // "baseline") shows when the "reference rows" box is ticked.
  document.querySelectorAll("fieldset.filters").forEach(function (set) {
    var table = document.getElementById(set.getAttribute("data-table"));
    var boxes = set.querySelectorAll("input[type=checkbox]");
    function apply() {
      var shown = {};
      Array.prototype.forEach.call(boxes, function (b) {
        shown[b.getAttribute("data-filter") + ":" + b.value] = b.checked;
      });
      Array.prototype.forEach.call(table.tBodies[0].rows, function (row) {
        var visible = row.classList.contains("baseline") ? shown["reference:reference"]
          : shown["protocol:" + row.getAttribute("data-protocol")] !== false;
        row.hidden = !visible;
      });
    }
    Array.prototype.forEach.call(boxes, function (b) { b.addEventListener("change", apply); });
    apply();
  });
})();
