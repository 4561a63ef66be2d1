--[[
What the Lua client's tests share (test_signing, test_reply_verification, test_state_verification):
check() prints one line per check ("ok" or "FAIL ... got, expected") and counts the failures;
finish(name) prints "<name> ok" or the count and exits 0 or 1 (ctest matches both lines); and the
byte helpers the vectors need.
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

return M
