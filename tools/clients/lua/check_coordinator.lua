--[[
Checks the Lua client against a running motion-coordinator (used by ctest test_clients): hears its
heartbeat, sends a request for an unknown axis and one with a non-finite value, prints one line per
check (same format as check_coordinator.py) and exits 0 when all came as expected, else 1.
  lua5.2 tools/clients/lua/check_coordinator.lua --lcm-url URL [--prefix MOTION_] [--axis x]
--]]
local motionclient = require("motionclient")
local reply_t, request_t = motionclient.reply_t, motionclient.request_t

local args, err = motionclient.parse_args(arg, {["--lcm-url"] = 1, ["--prefix"] = 1, ["--axis"] = 1})
if not args then
  io.stderr:write(err .. "\n")
  os.exit(2)
end
local ok, client = pcall(motionclient.new, {url = args["--lcm-url"] and args["--lcm-url"][1],
                                            prefix = args["--prefix"] and args["--prefix"][1] or "MOTION_",
                                            client_id = "check_coordinator.lua"})
if not ok then
  io.stderr:write("check_coordinator: LCM unavailable: " .. tostring(client) .. "\n")
  os.exit(4)
end

local all_ok = true
local h = client:wait_for_heartbeat("coordinator", 10)
if h then
  print(string.format("health: process=%s role=%s state=%s", h.process, h.role, motionclient.health_states[h.state] or tostring(h.state)))
else
  print("health: none within 10 s")
  all_ok = false
end
local r = client:request(request_t.MOVE_ABSOLUTE, {"no_such_axis"}, {1.0}, {timeout = 5})
print(string.format("unknown-axis: status=%s error_code=%d reason=%s", motionclient.status_name(r.status), r.error_code, r.reason))
all_ok = all_ok and r.status == reply_t.REJECTED and r.error_code == 2
r = client:request(request_t.MOVE_ABSOLUTE, {args["--axis"] and args["--axis"][1] or "x"}, {0 / 0}, {timeout = 5})
print(string.format("malformed: status=%s error_code=%d reason=%s", motionclient.status_name(r.status), r.error_code, r.reason))
all_ok = all_ok and r.status == reply_t.REJECTED and r.error_code == 1
io.stdout:flush()
os.exit(all_ok and 0 or 1)
