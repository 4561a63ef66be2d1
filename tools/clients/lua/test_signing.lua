--[[
Signing in the Lua client against the cross-language vector (tests/vectors/signed_request_v1.txt,
the bytes the C++ code produces): key file, payload, signed bytes, signature and the encoded
signed_request_t; the key file rules (mode 0600, one key line) and $MOTION_KEY's fallback. Prints
one line per check; exit 0 when all pass, else 1 (ctest clients_lua_signing).
  lua5.2 tools/clients/lua/test_signing.lua tests/vectors/signed_request_v1.txt
--]]
local signing = require("motionsigning")
local sodium = require("motionsodium")
local request_t = require("motionlcm.request_t")
local param_t = require("motionlcm.param_t")

local kit = require("motiontestkit")
local check = kit.check
local hex = kit.hex
local function words(s)
  local out = {}
  for w in s:gmatch("%S+") do out[#out + 1] = w end
  return out
end

local v = {}
for line in io.lines(arg[1]) do
  local name, value = line:match("^([^#][^=]-) = (.*)$")
  if name then v[name] = value end
end

local key_file = os.tmpname()
local function write_key(text, mode)
  local f = assert(io.open(key_file, "w"))
  f:write(text)
  f:close()
  assert(os.execute("chmod " .. mode .. " " .. key_file))
end
write_key("# the vector's key\n" .. v.key_file_line .. "\n", "600")

local key, err = signing.load_private_key(key_file)
check("key file loads", err, nil)
if key then
  check("key name", key.name, v.key_name)
  check("public key", hex(key.public_key), v.public_key_hex)
  check("key id", hex(key.key_id), v.key_id_hex)

  local r = request_t:new()
  r.utime = tonumber(v["request.utime"])
  r.client_id = v["request.client_id"]
  r.request_id = tonumber(v["request.request_id"])
  r.kind = tonumber(v["request.kind"])
  r.axes = words(v["request.axes"])
  r.values = {}
  for i, w in ipairs(words(v["request.values"])) do r.values[i] = tonumber(w) end
  r.num_axes = #r.axes
  r.velocity_scale = tonumber(v["request.velocity_scale"])
  r.acceleration_scale = tonumber(v["request.acceleration_scale"])
  r.timeout_ms = tonumber(v["request.timeout_ms"])
  r.output_mask = tonumber(v["request.output_mask"])
  r.output_value = tonumber(v["request.output_value"])
  r.param = param_t:new()
  r.param.mnemonic = ""

  local signer = signing.request_signer(key, v.prefix)
  local e = signer:sign(r, tonumber(v.utime))
  check("counter", string.format("%.0f", e.counter), v.counter)
  local payload = signing.bytes_of(e.payload)
  check("payload", hex(payload), v.payload_hex)
  check("signed bytes", hex(signing.signed_bytes(v.prefix, signing.bytes_of(e.key_id), e.counter, e.utime, payload)), v.signed_bytes_hex)
  check("signature", hex(signing.bytes_of(e.signature)), v.signature_hex)
  check("envelope", hex(e:encode()), v.envelope_hex)
  check("signature verifies", sodium.verify(key.public_key, signing.signed_bytes(v.prefix, key.key_id, e.counter, e.utime, payload),
                                            signing.bytes_of(e.signature)), true)
  check("next counter", string.format("%.0f", signer:sign(r, tonumber(v.utime)).counter), string.format("%.0f", tonumber(v.counter) + 1))
  check("own client id", signer:own_client_id("tool"), "vector/tool")
  check("own client id kept", signer:own_client_id("vector/tool"), "vector/tool")
end

write_key(v.key_file_line .. "\n", "644")
local _, refused = signing.load_private_key(key_file)
check("mode 0644 refused", refused and refused:find("is readable by group/others (mode 0644); chmod 600 it", 1, true) ~= nil, true)
write_key(v.key_file_line .. "\n" .. v.key_file_line .. "\n", "600")
_, refused = signing.load_private_key(key_file)
check("two key lines refused", refused and refused:find(":2: a second key line", 1, true) ~= nil, true)
os.remove(key_file)

check("key path: option first", signing.key_path("/option.key"), "/option.key")
check("key path: else $MOTION_KEY", signing.key_path(nil), os.getenv("MOTION_KEY"))

kit.finish("signing vector")
