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
  (as the C++ security::MessageVerifier), with motionsodium.verify (libsodium).

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

local Verifier = {}
Verifier.__index = Verifier

-- Takes a signed_message_t of `channel` (e.g. "REPLY") when, in this order, its channel is that
-- one, its key id is the coordinator's, the signature verifies, utime is within window_ms of the
-- receiver's clock and not before not_before_us (default: now), and the counter is above the last
-- one taken (a replay otherwise). coordinator: its 32-byte public key (load_public_key).
function M.message_verifier(coordinator, prefix, channel, window_ms, not_before_us)
  return setmetatable({coordinator = coordinator, key_id = coordinator:sub(1, M.KEY_ID_BYTES), prefix = prefix,
                       channel = channel, window_us = (window_ms or 2000) * 1000,
                       not_before_us = not_before_us or sodium.now_us(), last_counter = 0}, Verifier)
end

-- The message's bytes (a string), or nil and why it was refused.
function Verifier:verify(e, now_us)
  local what = "signed " .. self.channel .. " refused: "
  if e.channel ~= self.channel then return nil, what .. "it was signed for channel '" .. tostring(e.channel):sub(1, 64) .. "'" end
  local key_id = bytes_of(e.key_id)
  if key_id ~= self.key_id then
    return nil, what .. "key " .. M.hex(key_id) .. " is not the coordinator's (" .. M.hex(self.key_id) .. ")"
  end
  local message = bytes_of(e.message)
  local signature = bytes_of(e.signature)
  if #message ~= e.message_size or #signature ~= 64 or
      not sodium.verify(self.coordinator, M.message_signed_bytes(self.prefix, self.channel, key_id, e.counter, e.utime, message),
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
  if e.counter <= self.last_counter then
    return nil, string.format("%sreplayed counter %.0f (last accepted %.0f)", what, e.counter, self.last_counter)
  end
  self.last_counter = e.counter
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
