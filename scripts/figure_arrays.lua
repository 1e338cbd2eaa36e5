-- Quarto filter (see _quarto.yml) on the notebook pages: a figure whose cell saves the arrays
-- behind it (pkmlib.plotting.save_figure(fig, f"{figures_dir}/<name>.png", ..., arrays=...) writes
-- figures/<name>.npz beside the PNG) gets, under it, a link "arrays (.npz)" to that file, which
-- scripts/site_build.py post copies to <output-dir>/figures/. The cell is marked with the names
-- of the figures it saves (data-figures="p1_fig2_max_carriage_velocity ..."), which the site tests
-- use to find a figure's PNG and arrays from its image on the page.
local SAVED = 'save_figure%(%s*fig[%w_]*%s*,%s*f"{figures_dir}/([%w_%.]+)%.png"'

local function exists(path)
  local f = io.open(path, "rb")
  if f then f:close() return true end
  return false
end

local function names_in(code)
  local names = {}
  for name in code:gmatch(SAVED) do table.insert(names, name) end
  return names
end

function Pandoc(doc)
  local input = quarto.doc.input_file
  local dir = pandoc.path.directory(input)
  if pandoc.path.filename(dir) ~= "notebooks" or not input:match("%.ipynb$") then
    return doc
  end
  local root = pandoc.path.directory(dir)
  doc.blocks = doc.blocks:walk({
    Div = function(div)
      if not div.classes:includes("cell") then return nil end
      local names = {}
      for _, block in ipairs(div.content) do
        if block.t == "CodeBlock" then
          for _, n in ipairs(names_in(block.text)) do table.insert(names, n) end
        end
      end
      if #names == 0 then return nil end
      div.attributes["figures"] = table.concat(names, " ")
      local links = {}
      for _, n in ipairs(names) do
        if exists(root .. "/figures/" .. n .. ".npz") then
          table.insert(links, '<a class="figure-arrays" href="../figures/' .. n .. '.npz" download="' .. n ..
            '.npz"><i class="bi bi-download"></i> ' .. (#names > 1 and (n .. ': ') or '') .. 'arrays (.npz)</a>')
        end
      end
      if #links > 0 then
        div.content:insert(pandoc.RawBlock("html", '<p class="figure-arrays small">The arrays behind this figure, ' ..
          'with their units in their names (NumPy <code>np.load</code>): ' .. table.concat(links, " · ") .. '</p>'))
      end
      return div
    end,
  })
  return doc
end
