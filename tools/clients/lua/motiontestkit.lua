--[[
What the Lua client's tests share (test_signing, test_reply_verification, test_state_verification,
test_lost_datagrams): check() prints one line per check ("ok" or "FAIL ... got, expected") and
counts the failures; finish(name) prints "<name> ok" or the count and exits 0 or 1 (ctest matches
both lines); the byte helpers the vectors need; own_url(n), a test's own LCM URL; and reply(), a
reply_t with every field set.
--]]
local M = {failures = 0}

function M.check(what, actual, expected)
  local ok = tostring(actual) == tostring(expected)
  print((ok and "ok   " or "FAIL ") .. what .. (ok and "" or (": got " .. tostring(actual) .. ", expected " .. tostring(expected))))
  if not ok then M.failures = M.failures + 1 end
end

function M.finish(name)
  print(M.failures == 0 and (name .. " ok") or (M.failures .. " checks FAILED"))
  os.exit(M.failures == 0 and 0 or 1)
end

function M.unhex(s) return (s:gsub("%x%x", function(h) return string.char(tonumber(h, 16)) end)) end
function M.hex(s) return (s:gsub(".", function(c) return string.format("%02x", c:byte()) end)) end
function M.table_of(s) return {s:byte(1, -1)} end
-- "accepted" for a message a verifier took, else the reason it gave.
function M.refused(message, why) return message and "accepted" or why end

-- This process's own LCM URL (a multicast port of its own): n tells the tests of one process apart.
function M.own_url(n)
  local pid = tonumber(io.open("/proc/self/stat"):read("*l"):match("^(%d+)"))
  return string.format("udpm://239.255.76.67:%d?ttl=0", 20000 + (pid * 7 + n) % 40000)
end

-- A reply_t with every field set, as the coordinator would send it.
function M.reply(client_id, request_id, status, reason)
  local reply_t, param_t = require("motionlcm.reply_t"), require("motionlcm.param_t")
  local x = reply_t:new()
  x.utime = os.time() * 1000000
  x.client_id, x.request_id, x.status, x.reason = client_id, request_id, status, reason or ""
  x.error_code, x.progress, x.num_axes = 0, 0, 0
  x.axes, x.targets, x.positions, x.start_utime = {}, {}, {}, {}
  x.predicted_duration_s, x.predicted_skew_us, x.measured_start_skew_us = 0, 0, 0
  x.param = param_t:new()
  x.param.space, x.param.index, x.param.subindex, x.param.width, x.param.is_signed, x.param.value = 0, 0, 0, 0, false, 0
  x.param.mnemonic = ""
  return x
end

return M
