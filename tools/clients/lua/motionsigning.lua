--[[
Signed requests (README "Security") in the Lua client, byte-identical to the C++ client
(services/security): a request_t inside a signed_request_t on <prefix>SREQUEST, signed with an
Ed25519 key that `motionctl keygen` wrote. Ed25519 is libsodium's through the small native module
motionsodium (native/motionsodium.c, built as build/tools/clients/lua/motionsodium.so: put its
folder on LUA_CPATH); only the layout of the signed bytes is written here.

The signature covers, concatenated (lcmtypes/signed_request_t.lcm):
  "motionbus signed_request_t v1" NUL, channel prefix, NUL, key_id (8 bytes),
  counter (int64 big-endian), utime (int64 big-endian), payload_size (int32 big-endian), payload.

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
M.PRIVATE_TAG = "motionbus-ed25519-private-key"
M.KEY_ID_BYTES = 8

local function bytes_of(t) return string.char(unpack(t)) end  -- an LCM byte array (table) as a string
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
