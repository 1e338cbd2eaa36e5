-- Quarto filter (see _quarto.yml, run after Quarto's own filters): every table goes into a box
-- that scrolls sideways by itself (div.table-scroll, styles.css), so a table wider than the
-- column, or than a phone, never makes the page scroll sideways and is never cut off.
function Table(tbl)
  return pandoc.Div({tbl}, pandoc.Attr("", {"table-scroll"}))
end
