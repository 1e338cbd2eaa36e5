-- Quarto filter (see _quarto.yml): on each notebook page, under the title,
--   * the paper itself (its DOI, else its URL, else the journal's page, from references.bib; P5 prints
--     no DOI: its journal's page, with year, number and pages),
--   * links to the notebook (copied beside the page by scripts/site_build.py post), the results
--     JSON it writes, what the paper prints (data/reference) and its rows of the scorecard,
--   * a "re-run this page" box with the exact command (make rerun, the notebook's first
--     parameter as the example to change).
-- The notebook link is raw HTML marked data-noresolveinput, so Quarto keeps it pointing at the
-- .ipynb instead of the page's .html.
local KEYS = {p1 = "ispolov2025", p2 = "laryushkin2019", p3 = "shen2023", p4 = "erastova2020", p5 = "kheylo2022"}

local function read(path)
  local f = io.open(path, "r")
  if not f then return nil end
  local text = f:read("a")
  f:close()
  return text
end

local function esc(s)
  return (s:gsub("&", "&amp;"):gsub("<", "&lt;"):gsub(">", "&gt;"):gsub('"', "&quot;"))
end

-- {doi=..., url=..., journal=...} of a references.bib entry
local function bib_entry(root, key)
  local bib = read(root .. "/references.bib")
  if not bib then return {} end
  local body = bib:match("@%w+{" .. key .. ",(.-\n)}")
  if not body then return {} end
  local out = {}
  for field, value in body:gmatch("(%w+)%s*=%s*{(.-)},?%s*\n") do out[field] = value end
  return out
end

-- name and value of the first assignment in the notebook's `parameters` cell
local function first_parameter(path)
  local text = read(path)
  if not text then return nil end
  local json = (pandoc.json and pandoc.json.decode) or (quarto.json and quarto.json.decode)
  if not json then return nil end
  local ok, nb = pcall(json, text)
  if not ok or not nb.cells then return nil end
  for _, cell in ipairs(nb.cells) do
    local tags = (cell.metadata or {}).tags or {}
    for _, t in ipairs(tags) do
      if t == "parameters" then
        local src = type(cell.source) == "table" and table.concat(cell.source) or cell.source
        for line in src:gmatch("[^\n]+") do
          local name, value = line:match("^([%a_][%w_]*)%s*=%s*([^#]-)%s*#")
          if name and not value:match("^[%[\"']") then return name, value end
        end
      end
    end
  end
  return nil
end

function Pandoc(doc)
  local input = quarto.doc.input_file
  local name = pandoc.path.filename(input)
  local dir = pandoc.path.directory(input)
  if pandoc.path.filename(dir) ~= "notebooks" or not name:match("%.ipynb$") then
    return doc
  end
  local root = pandoc.path.directory(dir)
  local stem = name:gsub("%.ipynb$", "")
  local paper = name:match("^(p%d)_")
  local html = '<div class="source-links small">'
  if paper then
    local e = bib_entry(root, KEYS[paper])
    if e.doi then
      html = html .. 'Paper: <a class="paper-link" href="https://doi.org/' .. esc(e.doi) .. '">doi:' .. esc(e.doi) .. '</a>'
    elseif e.url and (e.note or ""):match("the journal's page") then
      -- no DOI and no article page printed: the journal's page, with the issue and pages to look up
      html = html .. 'Paper: ' .. esc(e.journal or "") .. ', ' .. esc(e.year or "") .. ', no. ' .. esc(e.number or "") ..
        ', pp. ' .. esc((e.pages or ""):gsub("%-%-", "-")) .. ' (no DOI printed): <a class="paper-link" href="' ..
        esc(e.url) .. '">the journal\'s page</a>'
    elseif e.url then
      html = html .. 'Paper: <a class="paper-link" href="' .. esc(e.url) .. '">' .. esc(e.url) .. '</a>'
    else
      html = html .. 'Paper: <span class="paper-link">' .. esc(e.journal or "") .. ', ' .. esc(e.year or "") ..
        ', no. ' .. esc(e.number or "") .. ', pp. ' .. esc((e.pages or ""):gsub("%-%-", "-")) ..
        ' (the paper prints no DOI or URL)</span>'
    end
    html = html .. ' · '
  end
  html = html .. 'Source: <a class="notebook-source" href="' .. name ..
    '" data-noresolveinput download="' .. name .. '"><i class="bi bi-journal-code"></i> ' .. name .. '</a>'
  if paper then
    html = html .. ' · results <a href="../data/results/' .. paper .. '.json">' .. paper .. '.json</a>' ..
      ' · the paper\'s numbers <a href="../data/reference/' .. paper .. '.json">' .. paper .. '.json</a>' ..
      ' · <a href="../scorecard.html#' .. paper .. '">scorecard rows</a>'
  end
  html = html .. '</div>'
  local pname, pvalue = first_parameter(input)
  local example = pname and (' PARAMS="-p ' .. pname .. ' ' .. pvalue .. '"') or ""
  html = html .. '<details class="rerun-box small"><summary>Re-run this page</summary>' ..
    '<p>From a clone of the repository (results and figures go to <code>runs/' .. stem .. '/</code>; the ' ..
    'paper\'s run stays as it is; change the value to yours):</p>' ..
    '<pre><code>make rerun NB=' .. stem .. esc(example) .. '\n' ..
    '.venv/bin/python -m pkmlib.tools.rerun ' .. stem .. ' --list   # every parameter and the paper\'s value</code></pre>' ..
    '<p><code>runs/' .. stem .. '/changes.md</code> lists every parameter, number and figure that changed. ' ..
    'A run at other values scores itself "not the paper\'s parameters".</p></details>'
  doc.blocks:insert(1, pandoc.RawBlock("html", html))
  return doc
end
