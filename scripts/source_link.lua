-- Quarto filter (see _quarto.yml): on each notebook page, a line under the title with links to
-- the notebook itself (copied beside the page by scripts/site_build.py post), the results JSON
-- it writes and its rows of the scorecard. The notebook link is raw HTML marked
-- data-noresolveinput, so Quarto keeps it pointing at the .ipynb instead of the page's .html.
function Pandoc(doc)
  local input = quarto.doc.input_file
  local name = pandoc.path.filename(input)
  local dir = pandoc.path.filename(pandoc.path.directory(input))
  if dir ~= "notebooks" or not name:match("%.ipynb$") then
    return doc
  end
  local paper = name:match("^(p%d)_")
  local html = '<div class="source-links small">Source: <a class="notebook-source" href="' .. name ..
    '" data-noresolveinput download="' .. name .. '"><i class="bi bi-journal-code"></i> ' .. name .. '</a>'
  if paper then
    html = html .. ' · results <a href="../data/results/' .. paper .. '.json">' .. paper .. '.json</a>' ..
      ' · <a href="../scorecard.html#' .. paper .. '">scorecard rows</a>'
  end
  html = html .. '</div>'
  doc.blocks:insert(1, pandoc.RawBlock("html", html))
  return doc
end
