--[[
Lost datagrams in the Lua client (ctest clients_lua_lost_datagrams): request() sends a request
again while nothing is heard of it (M.RESEND_AFTER before its first reply, M.QUIET_RESEND after),
as the C++ and Python clients do. A scripted coordinator on this test's own LCM URL answers each
copy of a request it hears with a list of replies; an empty list is a copy, or its replies, lost.
It listens on the client's own LCM instance (LCM hears its own datagrams), so the client's waits
pump it: one process, no thread.
 1. the first request lost: DONE all the same, after exactly 2 sends, equal but for utime;
 2. the first terminal reply lost: sent again once after the ACCEPTED, DONE;
 3. silence: FAILED "no reply from the coordinator within 2000 ms" after 4 sends (0, 0.5, 1, 1.5 s);
 4. the terminal reply heard twice, and an ACCEPTED after it (answers to copies sent again): the
    handler of send() and follow() gets accepted,done, the terminal reply once;
 5. signed, the request lost: the copy sent again has a new utime, counter and signature (which
    verifies), its payload the request's but for utime.
Prints one line per check; "FAIL ..." for each that failed, "lost datagrams ok" when all passed.
  lua5.2 tools/clients/lua/test_lost_datagrams.lua   (LUA_PATH, LUA_CPATH as ctest sets them)
--]]
local motionclient = require("motionclient")
local request_t, reply_t = motionclient.request_t, motionclient.reply_t
local signed_request_t = require("motionlcm.signed_request_t")
local signing = require("motionsigning")
local kit = require("motiontestkit")
local check = kit.check

local url = kit.own_url(2)
local ACCEPTED, DONE = reply_t.ACCEPTED, reply_t.DONE

-- A client and its scripted coordinator; each case its own channel prefix. With a key, the
-- client signs and the coordinator hears SREQUEST: copies holds the payloads, envelopes the rest.
local function lossy(case, script, key)
  local c = motionclient.new{url = url, prefix = case .. "_", client_id = "lua-test", key = key}
  local coordinator = {copies = {}, envelopes = {}}
  c.lc:subscribe(c.prefix .. (key and "SREQUEST" or "REQUEST"), function(_, data)
    local r
    if key then
      local e = signed_request_t.decode(data)
      coordinator.envelopes[#coordinator.envelopes + 1] = e
      r = request_t.decode(signing.bytes_of(e.payload))
    else
      r = request_t.decode(data)
    end
    coordinator.copies[#coordinator.copies + 1] = r
    for _, status in ipairs(table.remove(script, 1) or {}) do
      c.lc:publish(c.prefix .. "REPLY", kit.reply(r.client_id, r.request_id, status, "scripted"):encode())
    end
  end)
  return c, coordinator
end

-- The copies heard, each encoded with utime 0: equal when they differ in utime only.
local function same_but_utime(copies)
  local first
  for i, r in ipairs(copies) do
    r.utime = 0
    local bytes = r:encode()
    first = first or bytes
    if bytes ~= first then return "copy " .. i .. " differs" end
  end
  return #copies > 0 and "equal" or "none"
end

local function status_of(r)
  return motionclient.status_name(r.status) .. (r.error_code ~= 0 and (" " .. r.error_code) or "")
end

-- 1. The request lost.
local c, coordinator = lossy("LOST_REQUEST", {{}, {ACCEPTED, DONE}})
local r = c:request("move_absolute", {"x", "y"}, {1.5, -2}, {timeout = 5})
check("request lost: the terminal reply all the same", status_of(r), "done")
check("request lost: sends heard", #coordinator.copies, 2)
check("request lost: the copy sent again is the request, but for its utime", same_but_utime(coordinator.copies), "equal")
check("request lost: sent again", c.resent, 1)

-- 2. The terminal reply lost.
c, coordinator = lossy("LOST_DONE", {{ACCEPTED}, {DONE}})
local progress = {}
r = c:request("enable", {"x"}, nil, {timeout = 5, on_progress = function(p) progress[#progress + 1] = status_of(p) end})
check("terminal reply lost: asked for again, the terminal reply", status_of(r), "done")
check("terminal reply lost: sends heard", #coordinator.copies, 2)
check("terminal reply lost: the copy sent again is the request, but for its utime", same_but_utime(coordinator.copies), "equal")
check("terminal reply lost: progress replies", table.concat(progress, ","), "accepted")

-- 3. Silence.
c, coordinator = lossy("SILENCE", {})
r = c:request("enable", {"x"}, nil, {timeout = 5})
check("silence: a local failed reply (timeout)", status_of(r), "failed 13")
check("silence: it says nothing was heard",
      r.reason:match("^no reply from the coordinator within 2000 ms: is motion%-coordinator running on ") ~= nil, true)
check("silence: sends, at 0, 0.5, 1 and 1.5 s", #coordinator.copies, 4)
check("silence: the copies are the request, but for their utime", same_but_utime(coordinator.copies), "equal")

-- 4. The terminal reply heard again: passed on once.
c, coordinator = lossy("TWICE", {{ACCEPTED}, {DONE, DONE, ACCEPTED}})
local seen, terminal = {}, false
local id = c:send("enable", {"x"}, nil, function(x)
  seen[#seen + 1] = status_of(x)
  terminal = terminal or motionclient.is_terminal(x.status)
end)
local ended = c:follow(id, function() return terminal end, 5)
c:wait_until(function() return false end, 0.3)  -- the repeats arrive meanwhile
check("repeated terminal reply: the request ended", ended, true)
check("repeated terminal reply: passed on once", table.concat(seen, ","), "accepted,done")
check("repeated terminal reply: sends heard", #coordinator.copies, 2)

-- 5. Signed, the request lost.
local key = signing.key_from_seed(string.rep("\7", 32), "lost")
c, coordinator = lossy("SIGNED", {{}, {ACCEPTED, DONE}}, key)
r = c:request("enable", {"x"}, nil, {timeout = 5})
check("signed, request lost: the terminal reply", status_of(r), "done")
check("signed, request lost: sends heard", #coordinator.envelopes, 2)
local first, again = coordinator.envelopes[1], coordinator.envelopes[2] or coordinator.envelopes[1]
check("signed, request lost: a new utime and counter", again.utime > first.utime and again.counter > first.counter, true)
check("signed, request lost: the envelope's utime is the payload's", (coordinator.copies[2] or {}).utime, again.utime)
local verifies = signing.bytes_of(again.signature) ~= signing.bytes_of(first.signature) and require("motionsodium").verify(
    key.public_key, signing.signed_bytes(c.prefix, key.key_id, again.counter, again.utime, signing.bytes_of(again.payload)),
    signing.bytes_of(again.signature))
check("signed, request lost: signed anew, and the signature verifies", verifies, true)
check("signed, request lost: the payloads are the request, but for their utime", same_but_utime(coordinator.copies), "equal")

kit.finish("lost datagrams")
