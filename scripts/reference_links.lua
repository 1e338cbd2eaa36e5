-- Quarto filter (see _quarto.yml) for the API reference pages (reference/*.qmd, written by
-- quartodoc from the docstrings): a Sphinx role in a docstring (:func:`maximise`,
-- :meth:`create`, :class:`Grid`, :data:`...`) becomes a link to the entry it names, on whichever
-- reference page documents it; a name with no entry (a private module) keeps its code text and
-- loses the role. A link to an anchor that the page does not have (a summary table's attribute
-- row: Grid.axes, Decoupled6DofParams.inertia) points to the nearest entry that exists (the class).
local ROLES = {func = true, meth = true, class = true, data = true, attr = true, mod = true, obj = true,
               exc = true, const = true}

local anchors = nil   -- id -> page file name, over every reference page
local here = nil      -- this page's file name
local module = nil    -- this page's module (pkmlib.mechanisms.five_bar for mechanisms.five_bar.qmd)

local function load_anchors(dir)
  anchors = {}
  local pipe = io.popen('ls "' .. dir .. '"')
  if not pipe then return end
  for name in pipe:lines() do
    if name:match("%.qmd$") then
      local f = io.open(dir .. "/" .. name, "r")
      if f then
        for id in f:read("a"):gmatch("{ #([%w%._]+) }") do
          anchors[id] = anchors[id] or name
        end
        f:close()
      end
    end
  end
  pipe:close()
end

local function resolve(name)
  name = name:gsub("^~", ""):gsub("^%.", ""):gsub("%(%)$", "")
  local tries = {name, "pkmlib." .. name}
  if module then table.insert(tries, module .. "." .. name) end
  for _, id in ipairs(tries) do
    if anchors[id] then return id end
  end
  -- an entry ending in .name (a method named without its class): the only one on this page, else
  -- the only one on the whole reference
  local on_page, anywhere, n_page, n_any = nil, nil, 0, 0
  for id, page in pairs(anchors) do
    if id:sub(-(#name + 1)) == "." .. name then
      anywhere, n_any = id, n_any + 1
      if page == here then on_page, n_page = id, n_page + 1 end
    end
  end
  if n_page == 1 then return on_page end
  if n_page == 0 and n_any == 1 then return anywhere end
  return nil
end

local function target(id)
  if anchors[id] == here then return "#" .. id end
  return anchors[id] .. "#" .. id
end

local function roles(inlines)
  local out = pandoc.Inlines({})
  local i = 1
  while i <= #inlines do
    local el, nxt = inlines[i], inlines[i + 1]
    local before, role = nil, nil
    if el.t == "Str" then before, role = el.text:match("^(.-):(%a+):$") end
    if role and ROLES[role] and nxt and nxt.t == "Code" then
      if before ~= "" then out:insert(pandoc.Str(before)) end
      local id = resolve(nxt.text)
      local code = pandoc.Code((nxt.text:gsub("^~", "")))
      if id then out:insert(pandoc.Link({code}, target(id))) else out:insert(code) end
      i = i + 2
    else
      out:insert(el)
      i = i + 1
    end
  end
  return out
end

function Pandoc(doc)
  local input = quarto.doc.input_file
  local dir = pandoc.path.directory(input)
  if pandoc.path.filename(dir) ~= "reference" or not input:match("%.qmd$") then return doc end
  here = pandoc.path.filename(input)
  local stem = here:gsub("%.qmd$", "")
  module = stem:match("^mechanisms%.") and ("pkmlib." .. stem) or nil
  load_anchors(dir)
  local ids = {}
  doc:walk({
    Header = function(h) if h.identifier ~= "" then ids[h.identifier] = true end end,
    Div = function(d) if d.identifier ~= "" then ids[d.identifier] = true end end,
    Span = function(s) if s.identifier ~= "" then ids[s.identifier] = true end end,
  })
  return doc:walk({
    Inlines = roles,
    Link = function(link)
      local id = link.target:match("^#(.+)$")
      if not id or ids[id] then return nil end
      local prefix = id
      while prefix:find("%.") do
        prefix = prefix:gsub("%.[^%.]*$", "")
        if ids[prefix] then link.target = "#" .. prefix; return link end
      end
      return link.content
    end,
  })
end
