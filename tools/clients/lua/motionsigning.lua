--[[
Signed requests (README "Security") in the Lua client, byte-identical to the C++ client
(services/security): a request_t inside a signed_request_t on <prefix>SREQUEST, signed with an
Ed25519 key that `motionctl keygen` wrote. Ed25519 is libsodium's through the small native module
motionsodium (native/motionsodium.c, built as build/tools/clients/lua/motionsodium.so: put its
folder on LUA_CPATH); only the layout of the signed bytes is written here.

The signature covers, concatenated (lcmtypes/signed_request_t.lcm):
  "motionbus signed_request_t v1" NUL, channel prefix, NUL, key_id (8 bytes),
  counter (int64 big-endian), utime (int64 big-endian), payload_size (int32 big-endian), payload.

The coordinator's signed messages (signed_message_t, e.g. replies on SREPLY) cover
  "motionbus signed_message_t v1" NUL, prefix, NUL, channel, NUL, key_id, counter, utime,
  message_size, message (the same integers): message_signed_bytes; message_verifier checks them
  (as the C++ security::MessageVerifier), with motionsodium.verify (libsodium). Gateways sign their
  axis states the same way (SAXIS_STATE) with keys of role gateway: load_gateway_keys reads them
  from authorized_keys (with the buses a line's buses= binds each to), and a message_verifier of
  those keys checks the states (verify_message; Client:verify_states_with).

  local signing = require "motionsigning"
  local key = assert(signing.load_private_key(signing.key_path(opt_key)))   -- --key, else $MOTION_KEY
  client:sign_with(key)

Lua 5.2 numbers are doubles: utime and counters (µs since the epoch, about 2^51) are exact.
Thread contract: single-threaded.
--]]
local lcm = require("lcm")
local sodium = require("motionsodium")
local signed_request_t = require("motionlcm.signed_request_t")

local M = {}
M.REQUEST_DOMAIN = "motionbus signed_request_t v1"
M.MESSAGE_DOMAIN = "motionbus signed_message_t v1"
M.PRIVATE_TAG = "motionbus-ed25519-private-key"
M.KEY_ID_BYTES = 8

-- An LCM byte array (table) as a string, in slices (unpack has a limit on its results).
local function bytes_of(t)
  local parts = {}
  for i = 1, #t, 4096 do parts[#parts + 1] = string.char(unpack(t, i, math.min(i + 4095, #t))) end
  return table.concat(parts)
end
local function table_of(s) return {s:byte(1, -1)} end

function M.valid_name(name)
  return #name >= 1 and #name <= 64 and name:match("^[A-Za-z0-9._-]+$") ~= nil
end

function M.name_owns_client_id(name, client_id)
  return client_id == name or client_id:sub(1, #name + 1) == name .. "/"
end

local Key = {}
Key.__index = Key

-- A key pair from its 32-byte seed (a byte string) and its name.
function M.key_from_seed(seed, name)
  local self = setmetatable({name = name, seed = seed}, Key)
  self.public_key = sodium.public_key(seed)
  self.key_id = self.public_key:sub(1, M.KEY_ID_BYTES)
  return self
end

function Key:sign(message) return sodium.sign(self.seed, message) end

-- The key file to sign with: the option's value, else $MOTION_KEY (as motionctl --key); nil: unsigned.
function M.key_path(option)
  if option and option ~= "" then return option end
  local env = os.getenv("MOTION_KEY")
  if env and env ~= "" then return env end
  return nil
end

-- Reads a private key file as motionctl keygen writes it. Returns the key, or nil and what was
-- wrong (naming the file and line). Refuses a file group or others may access (as the C++ loader
-- does), and any other content than one key line.
function M.load_private_key(path)
  local mode, regular = sodium.file_mode(path)
  if not mode then return nil, "cannot read key file " .. path .. ": " .. regular end
  if not regular then return nil, "key file " .. path .. " is not a regular file" end
  if mode % 64 ~= 0 then  -- any of the group/others bits (077)
    local readable = math.floor(mode / 32) % 2 == 1 or math.floor(mode / 4) % 2 == 1
    return nil, string.format("key file %s is %s by group/others (mode %04o); chmod 600 it", path,
                              readable and "readable" or "accessible", mode)
  end
  local f, err = io.open(path, "r")
  if not f then return nil, "cannot read key file " .. path .. ": " .. err end
  local found, number = nil, 0
  for line in f:lines() do
    number = number + 1
    local fields = {}
    for w in line:gmatch("%S+") do fields[#fields + 1] = w end
    if #fields > 0 and fields[1]:sub(1, 1) ~= "#" then
      local where = path .. ":" .. number .. ": "
      local fail
      if found then
        fail = where .. "a second key line (a private key file holds one key)"
      elseif #fields ~= 3 or fields[1] ~= M.PRIVATE_TAG then
        fail = where .. "expected '" .. M.PRIVATE_TAG .. " <base64 seed> <name>' (is this a private key file? a .pub file is not)"
      else
        local seed = sodium.base64_decode(fields[2])
        if not seed or #seed ~= 32 then
          fail = where .. "the seed is not base64 of 32 bytes"
        elseif not M.valid_name(fields[3]) then
          fail = where .. "name '" .. fields[3] .. "' is not 1..64 of [A-Za-z0-9._-]"
        else
          found = M.key_from_seed(seed, fields[3])
        end
      end
      if fail then
        f:close()
        return nil, fail
      end
    end
  end
  f:close()
  if not found then return nil, "key file " .. path .. " holds no key line" end
  return found
end

-- What the signature covers (byte strings key_id and payload; the layout is in signed_request_t.lcm).
function M.signed_bytes(prefix, key_id, counter, utime, payload)
  return M.REQUEST_DOMAIN .. "\0" .. prefix .. "\0" .. key_id .. lcm._pack.pack(">qqi", counter, utime, #payload) .. payload
end

-- What the signature of a signed_message_t for `channel` covers (lcmtypes/signed_message_t.lcm).
function M.message_signed_bytes(prefix, channel, key_id, counter, utime, message)
  return M.MESSAGE_DOMAIN .. "\0" .. prefix .. "\0" .. channel .. "\0" ..
         key_id .. lcm._pack.pack(">qqi", counter, utime, #message) .. message
end

-- The 32-byte key (a byte string) of a public key file ("<base64 public key> <name> [<role>]", as
-- motionctl keygen writes <name>.pub), e.g. the coordinator's; nil and why when it is not one.
function M.load_public_key(path)
  local f, err = io.open(path, "r")
  if not f then return nil, "cannot read public key file " .. path .. ": " .. err end
  local number = 0
  for line in f:lines() do
    number = number + 1
    local first = line:match("^%s*(%S+)")
    if first and first:sub(1, 1) ~= "#" then
      f:close()
      local key = sodium.base64_decode(first)
      if not key or #key ~= 32 then
        return nil, path .. ":" .. number .. ": expected '<base64 public key> <name> [<role>]' (is this a .pub file?)"
      end
      return key
    end
  end
  f:close()
  return nil, "public key file " .. path .. " holds no key line"
end

M.ROLES = {"observe", "operate", "configure", "admin", "gateway"}
M.BUSES_TOKEN = "buses="

local function is_role(role)
  for _, r in ipairs(M.ROLES) do if r == role then return true end end
  return false
end

-- The principals of an authorized_keys file's text, as the C++ security::AuthorizedKeys reads it:
-- "<base64 public key> <name> <role> [buses=<bus>,...]", blank lines and # comments ignored. A list
-- of {public_key, name, role, buses (a list, or nil: every bus)}, or nil and every bad line
-- ("file:line: what was wrong", one per line).
function M.parse_authorized_keys(text, file_name)
  local out, errors, key_lines, name_lines, number = {}, {}, {}, {}, 0
  for line in (text .. "\n"):gmatch("([^\n]*)\n") do
    number = number + 1
    local f = {}
    for w in line:gmatch("%S+") do f[#f + 1] = w end
    if #f > 0 and f[1]:sub(1, 1) ~= "#" then
      local where = file_name .. ":" .. number .. ": "
      local key = sodium.base64_decode(f[1])
      local buses
      local fail
      if #f ~= 3 and #f ~= 4 then
        fail = string.format("expected '<base64 public key> <name> <role> [%s<bus>,...]', got %d field%s", M.BUSES_TOKEN, #f,
                             #f == 1 and "" or "s")
      elseif not key or #key ~= 32 then
        fail = "'" .. f[1]:sub(1, 16) .. (#f[1] > 16 and "...'" or "'") .. " is not a base64 Ed25519 public key (32 bytes)"
      elseif not M.valid_name(f[2]) then
        fail = "name '" .. f[2] .. "' is not 1..64 of [A-Za-z0-9._-]"
      elseif not is_role(f[3]) then
        fail = "unknown role '" .. f[3] .. "' (" .. table.concat(M.ROLES, ", ") .. ")"
      elseif #f == 4 then
        buses = {}
        for bus in (f[4]:sub(#M.BUSES_TOKEN + 1) .. ","):gmatch("([^,]*),") do buses[#buses + 1] = bus end
        local empty = false
        for _, bus in ipairs(buses) do empty = empty or bus == "" end
        if f[4]:sub(1, #M.BUSES_TOKEN) ~= M.BUSES_TOKEN or empty then
          fail = "expected '" .. M.BUSES_TOKEN .. "<bus>[,<bus>...]' after the role, got '" .. f[4]:sub(1, 64) .. "'"
        elseif f[3] ~= "gateway" then
          fail = M.BUSES_TOKEN .. " binds a key of role gateway to buses; '" .. f[2] .. "' has role " .. f[3]
        end
      end
      if not fail then
        local id = key:sub(1, M.KEY_ID_BYTES)  -- key ids are 8 bytes of the key
        if key_lines[id] then
          fail = string.format("key of '%s' is already listed at line %d (same key id %s)", f[2], key_lines[id], M.hex(id))
        elseif name_lines[f[2]] then
          fail = string.format("name '%s' is already used at line %d", f[2], name_lines[f[2]])
        else
          key_lines[id], name_lines[f[2]] = number, number
          out[#out + 1] = {public_key = key, name = f[2], role = f[3], buses = buses}
        end
      end
      if fail then errors[#errors + 1] = where .. fail end
    end
  end
  if #errors > 0 then return nil, table.concat(errors, "\n") end
  return out
end

-- The keys of role gateway of an authorized_keys file (security.authorized_keys), each
-- {public_key, name, buses}: what gateways sign their axis states with (Client:verify_states_with).
-- nil and why when the file cannot be read, has a bad line or no gateway key.
function M.load_gateway_keys(path)
  local f, err = io.open(path, "r")
  if not f then return nil, "cannot read authorized keys file " .. path .. ": " .. err end
  local text = f:read("*a")
  f:close()
  local principals, why = M.parse_authorized_keys(text, path)
  if not principals then return nil, why end
  local keys = {}
  for _, p in ipairs(principals) do
    if p.role == "gateway" then keys[#keys + 1] = p end
  end
  if #keys == 0 then return nil, "authorized keys file " .. path .. " has no key of role gateway" end
  return keys
end

local Verifier = {}
Verifier.__index = Verifier

-- Takes a signed_message_t of `channel` (e.g. "REPLY") when, in this order, its channel is that
-- one, its key id is the coordinator's, the signature verifies, utime is within window_ms of the
-- receiver's clock and not before not_before_us (default: now), and the counter is above the last
-- one taken from that key (a replay otherwise). coordinator: its 32-byte public key
-- (load_public_key); or a list of keys any of which may sign, e.g. load_gateway_keys(), with
-- signers_are naming them in a refusal ("a gateway key").
function M.message_verifier(coordinator, prefix, channel, window_ms, not_before_us, signers_are)
  local signers = {}
  if type(coordinator) == "string" then
    signers[coordinator:sub(1, M.KEY_ID_BYTES)] = {public_key = coordinator}
    signers_are = signers_are or ("the coordinator's (" .. M.hex(coordinator:sub(1, M.KEY_ID_BYTES)) .. ")")
  else
    for _, k in ipairs(coordinator) do signers[k.public_key:sub(1, M.KEY_ID_BYTES)] = k end
  end
  return setmetatable({signers = signers, signers_are = signers_are or "a key of the list", prefix = prefix,
                       channel = channel, window_us = (window_ms or 2000) * 1000,
                       not_before_us = not_before_us or sodium.now_us(), last_counter = {}}, Verifier)
end

-- Channel, signer, signature and freshness: the key id, the signer and the message's bytes when
-- they pass, else nil and why.
function Verifier:_check(e, now_us)
  local what = "signed " .. self.channel .. " refused: "
  if e.channel ~= self.channel then return nil, what .. "it was signed for channel '" .. tostring(e.channel):sub(1, 64) .. "'" end
  local key_id = bytes_of(e.key_id)
  local signer = self.signers[key_id]
  if not signer then return nil, what .. "key " .. M.hex(key_id) .. " is not " .. self.signers_are end
  local message = bytes_of(e.message)
  local signature = bytes_of(e.signature)
  if #message ~= e.message_size or #signature ~= 64 or
      not sodium.verify(signer.public_key, M.message_signed_bytes(self.prefix, self.channel, key_id, e.counter, e.utime, message),
                        signature) then
    return nil, what .. "bad signature (forged or altered in transit)"
  end
  if e.utime < self.not_before_us then return nil, what .. "stale timestamp: signed before this client started (a replay?)" end
  local age = math.abs(now_us - e.utime)
  if age > self.window_us then
    return nil, string.format("%sstale timestamp: signed %d ms %s, outside the window of %d ms (clocks out of sync, or a replay)",
                              what, math.floor(age / 1000), now_us >= e.utime and "ago" or "in the future",
                              math.floor(self.window_us / 1000))
  end
  return key_id, signer, message
end

-- Whether `counter` is above the last one taken from `key_id` for `bus` (then it is the last); else false and why.
function Verifier:_take_counter(key_id, bus, counter)
  local stream = key_id .. "/" .. bus
  local last = self.last_counter[stream] or 0
  if counter <= last then
    return false, string.format("signed %s refused: replayed counter %.0f (last accepted %.0f%s)", self.channel, counter, last,
                                bus == "" and "" or (" for " .. bus:sub(1, 64)))
  end
  self.last_counter[stream] = counter
  return true
end

-- The message's bytes (a string), or nil and why it was refused.
function Verifier:verify(e, now_us)
  local key_id, signer, message = self:_check(e, now_us)
  if not key_id then return nil, signer end
  local ok, why = self:_take_counter(key_id, "", e.counter)
  if not ok then return nil, why end
  return message
end

-- The message decoded as `lcm_type` (e.g. motionlcm.axis_state_t), or nil and why. The counter is
-- kept per key and bus_of(message), and a gateway key bound to buses (authorized_keys buses=)
-- vouches only for a message of one of them (checked before the counter, which a refused message
-- leaves as it was).
function Verifier:verify_message(e, now_us, lcm_type, bus_of)
  local key_id, signer, bytes = self:_check(e, now_us)
  if not key_id then return nil, signer end
  local decoded, message = pcall(lcm_type.decode, bytes)
  if not decoded then return nil, "signed " .. self.channel .. " refused: malformed message: " .. tostring(message) end
  local bus = bus_of(message)
  if signer.buses then
    local vouches = false
    for _, b in ipairs(signer.buses) do vouches = vouches or b == bus end
    if not vouches then
      return nil, string.format("signed %s refused: key %s ('%s') may vouch only for bus %s, not for bus %s", self.channel,
                                M.hex(key_id), signer.name, table.concat(signer.buses, ","), bus:sub(1, 64))
    end
  end
  local ok, why = self:_take_counter(key_id, bus, e.counter)
  if not ok then return nil, why end
  return message
end

function M.hex(s) return (s:gsub(".", function(c) return string.format("%02x", c:byte()) end)) end

local Signer = {}
Signer.__index = Signer

-- Signs a client's requests with one key for the channel prefix they go out on.
function M.request_signer(key, prefix)
  return setmetatable({key = key, prefix = prefix, last_counter = 0}, Signer)
end

-- client_id unchanged when it is the key's name or "<name>/...", else "<name>/<client_id>".
function Signer:own_client_id(client_id)
  if M.name_owns_client_id(self.key.name, client_id) then return client_id end
  return self.key.name .. "/" .. client_id
end

-- The signed_request_t of `request` (a motionlcm request_t), signed at now_us (µs since the
-- epoch) with the next counter, max(last + 1, now_us).
function Signer:sign(request, now_us)
  local e = signed_request_t:new()
  e.utime = now_us
  e.key_id = table_of(self.key.key_id)
  self.last_counter = math.max(self.last_counter + 1, now_us)
  e.counter = self.last_counter
  local payload = request:encode()
  e.payload = table_of(payload)
  e.payload_size = #payload
  e.signature = table_of(self.key:sign(M.signed_bytes(self.prefix, self.key.key_id, e.counter, e.utime, payload)))
  return e
end

M.bytes_of = bytes_of
-- The wall clock in µs since the epoch (signing times; os.time() has whole seconds only).
M.now_us = sodium.now_us
return M
