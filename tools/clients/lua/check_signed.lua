--[[
Checks signing in the Lua client against a coordinator with `security: {mode: enforce}` (used by
ctest test_clients): a signed enable and move of one axis, then the same move unsigned, signed
with a key the coordinator does not know, and with the right key but its signature altered
(forged); one line each, as check_signed.py prints them:
  signed: status=done ...   x = 12.5   unsigned: status=rejected error_code=19 ...
  stranger: status=rejected error_code=19 ...   forged: status=rejected error_code=19 ...
  after: x = 12.5 (unverified)
The "after" line (the axis's position from its axis state) ends in "(unverified)", or with
--gateway-keys (an authorized_keys file) in "(signed by a gateway, N refused)": the client then takes
only axis states signed by one of its keys of role gateway (verify_states_with).
Exit 0 when all came as expected, 1 otherwise, 2 bad command line or key file, 4 LCM unavailable.
  lua5.2 check_signed.lua --lcm-url URL [--prefix MOTION_] [--key FILE] --stranger-key FILE --axis x --target 12.5
                        [--gateway-keys FILE]
(--key defaults to $MOTION_KEY; LUA_CPATH must find motionsodium.so, see motionsigning.lua)
--]]
local motionclient = require("motionclient")
local signing = require("motionsigning")

local usage = "usage: check_signed.lua --lcm-url URL [--prefix MOTION_] [--key FILE] --stranger-key FILE --axis A --target P [--gateway-keys FILE]"
local args, err = motionclient.parse_args(arg, {["--lcm-url"] = 1, ["--prefix"] = 1, ["--key"] = 1, ["--stranger-key"] = 1,
                                               ["--axis"] = 1, ["--target"] = 1, ["--gateway-keys"] = 1})
local function first(name) return args and args[name] and args[name][1] end
local target = tonumber(first("--target"))
if not args or not target or not first("--stranger-key") then
  io.stderr:write((err or "--target and --stranger-key are needed") .. "\n" .. usage .. "\n")
  os.exit(2)
end
local axis = first("--axis") or "x"
local path = signing.key_path(first("--key"))
if not path then
  io.stderr:write("check_signed: no key: --key FILE or $MOTION_KEY\n")
  os.exit(2)
end
local key, key_err = signing.load_private_key(path)
local stranger, stranger_err = signing.load_private_key(first("--stranger-key"))
if not key or not stranger then
  io.stderr:write("check_signed: " .. (key_err or stranger_err) .. "\n")
  os.exit(2)
end
local gateways, gateways_err
if first("--gateway-keys") then
  gateways, gateways_err = signing.load_gateway_keys(first("--gateway-keys"))
  if not gateways then
    io.stderr:write("check_signed: --gateway-keys: " .. gateways_err .. "\n")
    os.exit(2)
  end
end

local function client(id, k)
  local ok, c = pcall(motionclient.new, {url = first("--lcm-url"), prefix = first("--prefix") or "MOTION_", client_id = id, key = k})
  if not ok then
    io.stderr:write("check_signed: LCM unavailable: " .. tostring(c) .. "\n")
    os.exit(4)
  end
  return c
end
local signed = client("check_signed.lua", key)
if gateways then signed:verify_states_with(gateways) end
local plain = client("check_signed.lua-plain", nil)
local other = client("check_signed.lua", stranger)
-- `key` whose signatures have one bit flipped: what an attacker altering a message gets.
local forged_key = setmetatable({}, {__index = key})
function forged_key:sign(message)
  local s = key:sign(message)
  return s:sub(1, 5) .. string.char(bit32.bxor(s:byte(6), 0x10)) .. s:sub(7)
end
local forger = client("check_signed.lua-forged", forged_key)

local function line(name, r)
  print(string.format("%s: status=%s error_code=%d reason=%s", name, motionclient.status_name(r.status), r.error_code, r.reason))
end

local r = signed:enable({axis}, {timeout = 10})
if r.status == motionclient.reply_t.DONE then r = signed:move({axis}, {target}, {timeout = 20}) end
line("signed", r)
local ok = r.status == motionclient.reply_t.DONE
if ok then
  for i = 1, r.num_axes do
    if r.axes[i] == axis then print(string.format("%s = %.6g", axis, r.positions[i])) end
  end
end
for _, c in ipairs({{"unsigned", plain}, {"stranger", other}, {"forged", forger}}) do
  r = c[2]:move({axis}, {target + 5.0}, {timeout = 5})
  line(c[1], r)
  ok = ok and r.status == motionclient.reply_t.REJECTED and r.error_code == motionclient.UNAUTHORIZED
end
-- A move that had been executed would have the axis on its way by now.
local until_us = signing.now_us() + 500000
while signing.now_us() < until_us do signed:handle(50) end
local s = signed:axis_states()[axis]
local verified = signed:states_verified() and string.format("(signed by a gateway, %d refused)", signed.forged_states) or "(unverified)"
print(s and string.format("after: %s = %.6g %s", axis, s.position, verified) or ("after: no state of " .. axis))
io.stdout:flush()
os.exit(ok and 0 or 1)
