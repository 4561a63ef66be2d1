--[[
Enables two axes, moves them together (one synchronized request) and prints their final positions.
  LUA_PATH="build/lcmtypes/lua/?.lua;build/lcmtypes/lua/?/init.lua;tools/clients/lua/?.lua;;" \
    lua5.2 tools/clients/lua/example_move.lua [--lcm-url URL] [--prefix MOTION_] [--axes x y] [--targets 10 5] [--timeout 60] [--key FILE]
--key (default $MOTION_KEY): sign the requests with this private key (motionctl keygen; needs
motionsodium.so on LUA_CPATH, see motionsigning.lua).
Exit codes: 0 done, 1 the coordinator refused or the move failed (its reason is printed),
2 bad command line, 4 LCM unavailable.
--]]
local motionclient = require("motionclient")

local usage = "usage: example_move.lua [--lcm-url URL] [--prefix MOTION_] [--axes A B] [--targets P Q] [--timeout S] [--key FILE]"
local args, err = motionclient.parse_args(arg, {["--lcm-url"] = 1, ["--prefix"] = 1, ["--axes"] = 2, ["--targets"] = 2,
                                               ["--timeout"] = 1, ["--key"] = 1, ["--help"] = 0})
if not args then
  io.stderr:write(err .. "\n" .. usage .. "\n")
  os.exit(2)
end
if args["--help"] then
  print(usage)
  os.exit(0)
end
local axes = args["--axes"] or {"x", "y"}
local targets = {}
for i, t in ipairs(args["--targets"] or {"10", "5"}) do
  targets[i] = tonumber(t)
  if not targets[i] then
    io.stderr:write("not a number: " .. t .. "\n" .. usage .. "\n")
    os.exit(2)
  end
end
local timeout = tonumber((args["--timeout"] or {tostring(motionclient.REQUEST_TIMEOUT)})[1])
if not timeout then
  io.stderr:write("--timeout: not a number\n" .. usage .. "\n")
  os.exit(2)
end

local key
do
  local option = args["--key"] and args["--key"][1]
  local path = (option ~= nil and option ~= "") and option or os.getenv("MOTION_KEY")  -- motionsigning.key_path
  if path and path ~= "" then
    local signing_ok, signing = pcall(require, "motionsigning")
    if not signing_ok then
      io.stderr:write("example_move: --key: signing unavailable: " .. tostring(signing) .. "\n")
      os.exit(2)
    end
    local key_err
    key, key_err = signing.load_private_key(path)
    if not key then
      io.stderr:write("example_move: --key: " .. key_err .. "\n")
      os.exit(2)
    end
  end
end

local ok, client = pcall(motionclient.new, {url = args["--lcm-url"] and args["--lcm-url"][1],
                                            prefix = args["--prefix"] and args["--prefix"][1] or "MOTION_",
                                            client_id = "example_move.lua", key = key})
if not ok then
  io.stderr:write("example_move: LCM unavailable: " .. tostring(client) .. "\n")
  os.exit(4)
end

local function fail(r)
  io.stderr:write(string.format("example_move: %s (error %d): %s\n", motionclient.status_name(r.status), r.error_code, r.reason))
  os.exit(1)
end

local r = client:enable(axes, {timeout = timeout})
if r.status ~= motionclient.reply_t.DONE then fail(r) end
print("enabled " .. table.concat(axes, " "))
r = client:move(axes, targets, {timeout = timeout, on_progress = function(p)
  print(string.format("  %s %5.1f%%", motionclient.status_name(p.status), p.progress * 100))
end})
if r.status ~= motionclient.reply_t.DONE then fail(r) end
for _, axis in ipairs(axes) do
  local pos = 0 / 0
  for i = 1, r.num_axes do
    if r.axes[i] == axis then pos = r.positions[i] end
  end
  print(string.format("%s = %.6g", axis, pos))
end
print(string.format("measured start skew %.1f us (predicted arrival spread %.1f us)", r.measured_start_skew_us, r.predicted_skew_us))
os.exit(0)
