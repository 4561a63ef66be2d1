--[[
Gateway-signed axis states in the Lua client (ctest clients_lua_state_verification):
 1. the gateway's signed state of tests/vectors/signed_state_v1.txt (the bytes the C++
    MessageSigner produces) verifies here, byte for byte, from a key for every bus and from a key
    bound to buses including the state's, and is refused from a key bound to another bus, replayed,
    altered, stale or under a key that is not a gateway key; load_gateway_keys reads only the
    gateway keys of an authorized_keys file, with their buses, and names every bad line;
 2. a client after verify_states_with(keys), on its own LCM URL: a plain forged state, one signed
    with a stranger's key, a tampered one, a replayed one and one from a key bound to another bus
    are not taken (c.forged_states counts the signed ones); the gateways' signed states are;
    without verify_states_with the plain state is taken and states_verified() is false.
Prints one line per check; "FAIL ..." for each that failed, "state verification ok" when all passed.
  lua5.2 tools/clients/lua/test_state_verification.lua tests/vectors/signed_state_v1.txt
--]]
local lcm = require("lcm")
local signing = require("motionsigning")
local motionclient = require("motionclient")
local axis_state_t = require("motionlcm.axis_state_t")
local signed_message_t = require("motionlcm.signed_message_t")

local kit = require("motiontestkit")
local check = kit.check
local unhex = kit.unhex
local table_of = kit.table_of
local refused = kit.refused
local function bus_of(m) return m.bus end

local v = {}
for line in io.lines(arg[1]) do
  local name, value = line:match("^([^#][^=]-) = (.*)$")
  if name then v[name] = value end
end

local operator_line = "A6EHv/POEL4dcN0Y50vAmWfk1jCbpQ1fHdyGZBJVMbg= alice operate"
local function keys(...)
  local text = "# the lab's principals\n" .. operator_line .. "\n" .. table.concat({...}, "\n") .. "\n"
  local principals, why = signing.parse_authorized_keys(text, "authorized_keys")
  if not principals then return nil, why end
  local out = {}
  for _, p in ipairs(principals) do if p.role == "gateway" then out[#out + 1] = p end end
  return out
end
local function verifier(k, not_before_us) return signing.message_verifier(k, v.prefix, "AXIS_STATE", 2000, not_before_us, "a gateway key") end

-- What a gateway's MessageSigner makes (the vector shows these bytes are C++'s).
local function sign(key, prefix, message, utime, counter)
  local e = signed_message_t:new()
  e.utime, e.counter, e.channel = utime, counter, "AXIS_STATE"
  e.key_id = table_of(key.key_id)
  local bytes = message:encode()
  e.message, e.message_size = table_of(bytes), #bytes
  e.signature = table_of(key:sign(signing.message_signed_bytes(prefix, "AXIS_STATE", key.key_id, counter, utime, bytes)))
  return e
end

-- 1. The vector.
local key_file = os.tmpname()
do
  local f = assert(io.open(key_file, "w"))
  f:write(v.key_file_line .. "\n")
  f:close()
  assert(os.execute("chmod 600 " .. key_file))
end
local gateway = assert(signing.load_private_key(key_file))
os.remove(key_file)
check("vector: public key of the key file", signing.hex(gateway.public_key), v.public_key_hex)
local envelope = signed_message_t.decode(unhex(v.envelope_hex))
local at = tonumber(v.utime)
check("vector: Lua signs the C++ gateway's bytes",
      signing.hex(sign(gateway, v.prefix, axis_state_t.decode(unhex(v.message_hex)), at, envelope.counter):encode()), v.envelope_hex)
for _, line in ipairs({"authorized_every_bus", "authorized_bound"}) do
  local ver = verifier(assert(keys(v[line])), at - 1000)
  local s, why = ver:verify_message(envelope, at + 500, axis_state_t, bus_of)
  check("vector: C++'s signed state verifies (" .. line .. ")", s and string.format("%s %s %g", s.axis, s.bus, s.position) or why, "x can0 10.5")
  check("vector: the state's bytes (" .. line .. ")", s and signing.hex(s:encode()) or "", v.message_hex)
  check("vector: replayed (" .. line .. ")", refused(ver:verify_message(envelope, at + 600, axis_state_t, bus_of)), v.refused_replayed)
end
local other_bus = verifier(assert(keys(v.authorized_other_bus)), at - 1000)
check("vector: a key bound to another bus", refused(other_bus:verify_message(envelope, at + 500, axis_state_t, bus_of)), v.refused_other_bus)
local every_bus = assert(keys(v.authorized_every_bus))
local altered = signed_message_t.decode(unhex(v.envelope_hex))
altered.message[#altered.message - 19] = (altered.message[#altered.message - 19] + 1) % 256
check("vector: altered", refused(verifier(every_bus, 0):verify_message(altered, at, axis_state_t, bus_of)),
      "signed AXIS_STATE refused: bad signature (forged or altered in transit)")
check("vector: stale", refused(verifier(every_bus, 0):verify_message(envelope, at + 2500000, axis_state_t, bus_of)),
      "signed AXIS_STATE refused: stale timestamp: signed 2500 ms ago, outside the window of 2000 ms (clocks out of sync, or a replay)")
local stranger = signing.key_from_seed(string.rep("\0", 32), "stranger")
check("vector: not a gateway key",
      refused(verifier({{public_key = stranger.public_key, name = "stranger"}}, 0):verify_message(envelope, at, axis_state_t, bus_of)),
      "signed AXIS_STATE refused: key " .. v.public_key_hex:sub(1, 16) .. " is not a gateway key")
local two = assert(keys(v.authorized_bound, "O2onvM62pC1io6jQKm8Nc2UyFXcd4kOmOsBIoYtZ2ik= gw2 gateway"))
check("keys: only the gateway keys, with their buses",
      string.format("%d %s [%s] %s %s", #two, two[1].name, table.concat(two[1].buses, ","), two[2].name, tostring(two[2].buses)),
      "2 vector [rs485a,can0] gw2 nil")
check("keys: every bad line named",
      select(2, keys(v.authorized_every_bus .. " extra more", operator_line:gsub("alice", "bob") .. " buses=can0",
                     (v.authorized_other_bus:gsub("rs485a", ""):gsub("vector", "v2")),
                     "O2onvM62pC1io6jQKm8Nc2UyFXcd4kOmOsBIoYtZ2ik= gw2 gateway busses=can0")),
      "authorized_keys:3: expected '<base64 public key> <name> <role> [buses=<bus>,...]', got 5 fields\n" ..
      "authorized_keys:4: buses= binds a key of role gateway to buses; 'bob' has role operate\n" ..
      "authorized_keys:5: expected 'buses=<bus>[,<bus>...]' after the role, got 'buses='\n" ..
      "authorized_keys:6: expected 'buses=<bus>[,<bus>...]' after the role, got 'busses=can0'")
do
  local path = os.tmpname()
  local f = assert(io.open(path, "w"))
  f:write(operator_line .. "\n")
  f:close()
  check("keys: a file without a gateway key", select(2, signing.load_gateway_keys(path)), "authorized keys file " .. path .. " has no key of role gateway")
  os.remove(path)
end

-- 2. A verifying client on its own LCM URL.
local function state(position, fault, bus)
  local s = axis_state_t:new()
  s.utime = signing.now_us()
  s.sample_utime = s.utime
  s.axis, s.family, s.bus, s.fault_text = "x", "uim342", bus, ""
  s.node_id, s.group_id, s.position_counts, s.velocity, s.target_counts = 0, 0, 0, 0, 0
  s.online, s.enabled, s.moving, s.in_position, s.homed = true, true, false, true, true
  s.position, s.fault, s.fault_code, s.inputs, s.outputs = position, fault, 0, 0, 0
  return s
end
local can0 = signing.key_from_seed(string.rep("\4", 32), "gateway-can0")
local rs485 = signing.key_from_seed(string.rep("\5", 32), "gateway-rs485a")
-- Their authorized_keys lines (base64 of can0's and rs485's public keys), each bound to its bus.
local keys_file = os.tmpname()
do
  local f = assert(io.open(keys_file, "w"))
  f:write("ypOsFwUYcHHWe4PH/w7+gQjo7EUwV113JoeTM9vavnw= gateway-can0 gateway buses=can0\n" ..
          "bnoc3Smwt4/ROvTFWY/v9O8qlxZuPKby5Pv8zYBQW/E= gateway-rs485a gateway buses=rs485a\n")
  f:close()
end
local gateways = assert(signing.load_gateway_keys(keys_file))
os.remove(keys_file)
check("keys: the file's keys", signing.hex(gateways[1].public_key .. gateways[2].public_key), signing.hex(can0.public_key .. rs485.public_key))
local url = kit.own_url(6)
local prefix = "MOTION_"
local c = motionclient.new{url = url, prefix = prefix, client_id = "lua-test"}
local wire = lcm.lcm.new(url)
local seen = {}
c:on_axis_state(function(s) seen[#seen + 1] = s end)
wire:publish(prefix .. "AXIS_STATE", state(1.0, false, "can0"):encode())
c:wait_until(function() return #seen > 0 end, 20)
check("client: unverifying, the plain state is taken", string.format("%s %s", seen[1] and seen[1].position, tostring(c:states_verified())),
      "1 false")

c:verify_states_with(gateways, 2000)
check("client: verifying forgets the unverified states", tostring(next(c:axis_states())) .. " " .. tostring(c:states_verified()), "nil true")
seen = {}
local now = signing.now_us()
local genuine = sign(can0, prefix, state(2.0, false, "can0"), now, now):encode()
wire:publish(prefix .. "SAXIS_STATE", genuine)
local lie = state(99.0, true, "can0")
wire:publish(prefix .. "AXIS_STATE", lie:encode())  -- plain forged: ignored, like every plain copy
wire:publish(prefix .. "SAXIS_STATE", sign(signing.key_from_seed(string.rep("\9", 32), "gateway-can0"), prefix, lie, now, now):encode())
local tampered = sign(can0, prefix, lie, now, now + 1)
tampered.signature[8] = (tampered.signature[8] + 32) % 256
wire:publish(prefix .. "SAXIS_STATE", tampered:encode())
wire:publish(prefix .. "SAXIS_STATE", genuine)  -- replayed
wire:publish(prefix .. "SAXIS_STATE", sign(rs485, prefix, lie, now, now):encode())  -- rs485a's key, bus can0
wire:publish(prefix .. "SAXIS_STATE", sign(rs485, prefix, state(3.0, false, "rs485a"), now, now + 1):encode())
wire:publish(prefix .. "SAXIS_STATE", sign(can0, prefix, state(4.0, false, "can0"), now, now + 2):encode())
-- In order on one socket: once the last genuine state is here, everything before it was handled.
c:wait_until(function() return #seen > 0 and seen[#seen].position == 4.0 end, 20)
local got = {}
for _, s in ipairs(seen) do got[#got + 1] = string.format("%s:%g", s.bus, s.position) end
check("client: only the gateways' signed states for their buses are taken", table.concat(got, ","), "can0:2,rs485a:3,can0:4")
check("client: forged signed states counted (stranger, tampered, replayed, another bus's key)", c.forged_states, 4)
local x = c:axis_states().x
check("client: the axis's state is the gateway's", x and string.format("%s:%g", x.bus, x.position) or "none", "can0:4")

kit.finish("state verification")
