-- wrk script: distinct /mesh views of one image, so that no answer comes from the response cache
-- (tests/bench/README.md, "mesh_json_bench"). The i-th request is the i-th view of
-- mesh_json_bench.cc's query(): 480×360, zoom cycling through 0.2, 0.4, 0.6, 0.8, 1, the centre
-- stepping across the image (on a 20 MP image millions of views before one repeats). START, the
-- first view's i, lets runs against one server ask for views it has not cached yet. With
-- "morph", each view comes with its geomorph pair (from_zoom 0.1 lower). Use one thread (-t1):
-- each wrk thread counts from START.
--
--   wrk -t1 -c4 -d10s -s tests/bench/mesh_views.lua http://127.0.0.1:PORT -- IMAGE_ID WIDTH HEIGHT START [morph]

local zooms = { "0.2", "0.4", "0.6", "0.8", "1" }
local from_zooms = { "0.1", "0.3", "0.5", "0.7", "0.9" }
local id, width, height, morph
local i = 0

function init(args)
  id, width, height, i, morph = args[1], tonumber(args[2]), tonumber(args[3]), tonumber(args[4]), args[5] == "morph"
end

function request()
  local cx = math.floor(width / 10) + (i * 97) % math.floor(width * 8 / 10)
  local cy = math.floor(height / 10) + (i * 61) % math.floor(height * 8 / 10)
  local path = string.format("/v1/images/%s/mesh?w=480&h=360&zoom=%s&cx=%d&cy=%d", id, zooms[i % 5 + 1], cx, cy)
  if morph then path = path .. "&from_zoom=" .. from_zooms[i % 5 + 1] end
  i = i + 1
  return wrk.format("GET", path)
end

-- Any answer but 2xx makes the figures meaningless: say how many there were.
function done(summary)
  local errors = summary.errors.status + summary.errors.connect + summary.errors.read + summary.errors.write
  io.write(string.format("non-2xx or socket errors: %d\n", errors))
end
