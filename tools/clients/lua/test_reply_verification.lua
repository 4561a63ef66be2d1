--[[
Verified replies in the Lua client (ctest clients_lua_reply_verification):
 1. the coordinator's signed reply of tests/vectors/signed_reply_v1.txt (the bytes the C++
    MessageSigner produces) verifies here, byte for byte, and is refused replayed, stale, for
    another prefix or channel, altered, or under another key;
 2. a client after verify_with(coordinator's key), on its own LCM URL: a plain REPLY, a reply
    signed with another key, one whose signature was altered and a replayed one do not end its
    request (forged_replies counts the signed ones); the coordinator's signed replies do; a plain
    SECURITY event naming a pending request does not end it either.
Prints one line per check; "FAIL ..." for each that failed, "reply verification ok" when all passed.
  lua5.2 tools/clients/lua/test_reply_verification.lua tests/vectors/signed_reply_v1.txt
--]]
local lcm = require("lcm")
local signing = require("motionsigning")
local motionclient = require("motionclient")
local reply_t = require("motionlcm.reply_t")
local event_t = require("motionlcm.event_t")
local signed_message_t = require("motionlcm.signed_message_t")

local kit = require("motiontestkit")
local check = kit.check
local unhex = kit.unhex
local table_of = kit.table_of
local refused = kit.refused
local reply = kit.reply

local v = {}
for line in io.lines(arg[1]) do
  local name, value = line:match("^([^#][^=]-) = (.*)$")
  if name then v[name] = value end
end

local key_file = os.tmpname()
do
  local f = assert(io.open(key_file, "w"))
  f:write(v.key_file_line .. "\n")
  f:close()
  assert(os.execute("chmod 600 " .. key_file))
end
local coordinator = assert(signing.load_private_key(key_file))
os.remove(key_file)

-- What the coordinator's MessageSigner makes (the vector shows these bytes are C++'s).
local function sign(key, prefix, channel, message, utime, counter)
  local e = signed_message_t:new()
  e.utime, e.counter, e.channel = utime, counter, channel
  e.key_id = table_of(key.key_id)
  local bytes = message:encode()
  e.message, e.message_size = table_of(bytes), #bytes
  e.signature = table_of(key:sign(signing.message_signed_bytes(prefix, channel, key.key_id, counter, utime, bytes)))
  return e
end

-- 1. The vector.
local pub = unhex(v.public_key_hex)
check("vector: public key of the key file", signing.hex(coordinator.public_key), v.public_key_hex)
local envelope = signed_message_t.decode(unhex(v.envelope_hex))
local at = tonumber(v.utime)
local message_bytes = signing.bytes_of(envelope.message)
check("vector: signed bytes", signing.hex(signing.message_signed_bytes(v.prefix, envelope.channel, signing.bytes_of(envelope.key_id),
                                                                      envelope.counter, envelope.utime, message_bytes)),
      v.signed_bytes_hex)
check("vector: Lua's signature is C++'s",
      signing.hex(signing.bytes_of(sign(coordinator, v.prefix, "REPLY", reply_t.decode(message_bytes), envelope.utime, envelope.counter).signature)),
      v.signature_hex)
local verifier = signing.message_verifier(pub, v.prefix, "REPLY", 2000, at - 1000)
local message, why = verifier:verify(envelope, at + 500)
check("vector: C++'s signed reply verifies", message and signing.hex(message) or why, v.message_hex)
local r = message and reply_t.decode(message)
check("vector: the reply inside", r and (r.client_id .. " " .. string.format("%.0f", r.request_id)),
      v["reply.client_id"] .. " " .. v["reply.request_id"])
check("vector: replayed", refused(verifier:verify(envelope, at + 600)),
      string.format("signed REPLY refused: replayed counter %s (last accepted %s)", v.counter, v.counter))
local late = signing.message_verifier(pub, v.prefix, "REPLY", 2000, 0)
check("vector: stale", refused(late:verify(envelope, at + 2500000)),
      "signed REPLY refused: stale timestamp: signed 2500 ms ago, outside the window of 2000 ms (clocks out of sync, or a replay)")
local started = signing.message_verifier(pub, v.prefix, "REPLY", 2000, at + 1)
check("vector: signed before the client started", refused(started:verify(envelope, at)),
      "signed REPLY refused: stale timestamp: signed before this client started (a replay?)")
local other = signing.message_verifier(pub, "OTHER_", "REPLY", 2000, 0)
check("vector: another prefix", refused(other:verify(envelope, at)), "signed REPLY refused: bad signature (forged or altered in transit)")
local events = signing.message_verifier(pub, v.prefix, "EVENT", 2000, 0)
check("vector: another channel", refused(events:verify(envelope, at)), "signed EVENT refused: it was signed for channel 'REPLY'")
local altered = signed_message_t.decode(unhex(v.envelope_hex))
altered.message[#altered.message - 19] = (altered.message[#altered.message - 19] + 1) % 256
local fresh = signing.message_verifier(pub, v.prefix, "REPLY", 2000, 0)
check("vector: altered", refused(fresh:verify(altered, at)), "signed REPLY refused: bad signature (forged or altered in transit)")
local stranger = signing.key_from_seed(string.rep("\0", 32), "coordinator")
local strangers = signing.message_verifier(stranger.public_key, v.prefix, "REPLY", 2000, 0)
check("vector: another key", refused(strangers:verify(envelope, at)),
      "signed REPLY refused: key " .. v.public_key_hex:sub(1, 16) .. " is not the coordinator's (" .. signing.hex(stranger.key_id) .. ")")

-- 2. A verifying client on its own LCM URL.
local url = kit.own_url(5)
local prefix = "MOTION_"
local c = motionclient.new{url = url, prefix = prefix, client_id = "lua-test"}
local wire = lcm.lcm.new(url)
c:verify_with(pub, 2000)
local seen = {}
local rid = c:send("move_absolute", {"x"}, {1.0}, function(x) seen[#seen + 1] = x end)
local now = signing.now_us()
wire:publish(prefix .. "REPLY", reply(c.id, rid, reply_t.FAILED, "plain lie"):encode())
wire:publish(prefix .. "SREPLY", sign(stranger, prefix, "REPLY", reply(c.id, rid, reply_t.FAILED, "another key"), now, now):encode())
local bad = sign(coordinator, prefix, "REPLY", reply(c.id, rid, reply_t.FAILED, "altered"), now, now + 1)
bad.signature[8] = (bad.signature[8] + 32) % 256
wire:publish(prefix .. "SREPLY", bad:encode())
local progress = sign(coordinator, prefix, "REPLY", reply(c.id, rid, reply_t.PROGRESS, ""), now, now + 2):encode()
wire:publish(prefix .. "SREPLY", progress)
wire:publish(prefix .. "SREPLY", progress)  -- replayed
-- A SECURITY event naming the request, plain (not the coordinator's signed one): ignored.
local lie = event_t:new()
lie.utime, lie.source, lie.axis, lie.bus, lie.node_id, lie.severity, lie.kind, lie.code = now, "coordinator", "", "", 0, 0, event_t.SECURITY, 0
lie.text = string.format("signed request refused: bad signature: request %.0f of client '%s'", rid, c.id)
wire:publish(prefix .. "EVENT", lie:encode())
wire:publish(prefix .. "SREPLY", sign(coordinator, prefix, "REPLY", reply(c.id, rid, reply_t.DONE, "moved"), now, now + 3):encode())
-- In order on one socket: once a terminal reply is here, everything published before it was handled.
c:wait_until(function() return #seen > 0 and motionclient.is_terminal(seen[#seen].status) end, 20)
local names = {}
for _, x in ipairs(seen) do names[#names + 1] = motionclient.status_name(x.status) .. (x.error_code ~= 0 and (" " .. x.error_code) or "") end
check("client: only the coordinator's signed replies end the request", table.concat(names, ","), "progress,done")
check("client: the terminal reply is the coordinator's", #seen > 0 and seen[#seen].reason or "", "moved")
check("client: forged signed replies counted (another key, altered, replayed)", c.forged_replies, 3)

kit.finish("reply verification")
