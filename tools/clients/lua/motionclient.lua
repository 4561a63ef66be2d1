--[[
Lua client of the motion system, on Debian's LCM binding for Lua 5.2 (liblcm-lua: require "lcm")
and the lcm-gen Lua types (build/lcmtypes/lua on LUA_PATH: "build/lcmtypes/lua/?.lua;...").
Requests and their terminal replies, axis state, events, heartbeats; mirrors the C++ client
(services/client): every request gets replies on REPLY that end in exactly one terminal status
(DONE, REJECTED, ABORTED, FAILED); request() waits for it.

  local motionclient = require "motionclient"
  local c = motionclient.new{url = "udpm://239.255.76.67:7667?ttl=0", prefix = "MOTION_", client_id = "my-tool"}
  local r = c:request("enable", {"x", "y"}, nil, {timeout = 10})
  print(motionclient.status_name(r.status), r.error_code, r.reason)

Signing (README "Security"): after c:sign_with(key) (motionsigning.load_private_key) every request
goes out signed on SREQUEST, byte-identical to the C++ client; opts.key = key in new() does the
same. A SECURITY event of the coordinator naming a pending request (unsigned, unknown key, bad
signature...: the coordinator sends no reply) ends it at once with a local REJECTED, code 19.
motionsigning needs the native module motionsodium on LUA_CPATH; without signing it is not loaded.

Verified replies: after c:verify_with(coordinator_public_key) (motionsigning.load_public_key of
security.coordinator_public_key) only the coordinator's signed replies and SECURITY events count
(signed_message_t on SREPLY, SEVENT), as in the C++, Python and Java clients: a plain REPLY is
ignored (the coordinator's own come signed too), and a signed one that does not verify (another
key, altered, stale, replayed) is a forgery: the request goes on waiting and c.forged_replies
counts it.

Verified axis states: after c:verify_states_with(motionsigning.load_gateway_keys(authorized_keys))
only states signed by a key of role gateway count (signed_message_t on SAXIS_STATE; channel, key,
signature, window, counter per key and bus, a key bound to buses only for those), as in the C++
client: plain AXIS_STATEs are ignored and signed ones that do not verify are counted
(c.forged_states). Without it the plain states are taken, unverified (c:states_verified() is false:
say so where they are shown).

Lost datagrams (README "Safety and faults"): LCM delivers nothing for sure. While request() or
follow() waits on a request, the request is sent again, unchanged but for its send time (and
signature), whenever nothing has been heard of it for M.RESEND_AFTER seconds (before its first
reply) or M.QUIET_RESEND (after), as the C++ and Python clients do: the coordinator answers a
request sent again with its latest reply to it, word for word, and runs nothing twice. A reply
heard again after the terminal one is not passed on: each request ends in exactly one terminal
reply.

Thread contract: single-threaded. Callbacks run inside handle(), request(), follow() and
wait_until(), which pump LCM. Timeouts are in seconds, measured with the monotonic clock of the
native module motionsodium when it is on LUA_CPATH, else LuaSocket's socket.gettime, else
os.time() (Lua 5.2 has no finer clock of its own: whole seconds, at least the requested time, and
a request is then sent again at most once a second).
--]]

local lcm = require("lcm")
local request_t = require("motionlcm.request_t")
local reply_t = require("motionlcm.reply_t")
local param_t = require("motionlcm.param_t")
local axis_state_t = require("motionlcm.axis_state_t")
local event_t = require("motionlcm.event_t")
local health_t = require("motionlcm.health_t")

local M = {}

-- A clock in seconds with a fraction, if there is one (see "Thread contract" above).
local function fine_clock()
  local has_native, native = pcall(require, "motionsodium")
  if has_native and native.monotonic then return native.monotonic end
  local has_socket, socket = pcall(require, "socket")
  if has_socket and socket.gettime then return socket.gettime end
  return nil
end
local clock = fine_clock()
local function now()
  return clock and clock() or os.time()
end
-- Deadline `timeout` seconds from now; with whole-second clocks, never earlier than asked.
local function deadline_after(timeout)
  if clock then return now() + timeout end
  return os.time() + math.ceil(timeout) + 1
end

M.request_t, M.reply_t, M.axis_state_t, M.event_t, M.health_t = request_t, reply_t, axis_state_t, event_t, health_t
-- The coordinator answers every request at once; no reply within this many seconds means no
-- coordinator is listening (the same bound as the C++ client's kAcceptTimeout).
M.ACCEPT_TIMEOUT = 2.0
-- Lost datagrams: a pending request of which nothing has been heard for RESEND_AFTER seconds
-- (before its first reply) or QUIET_RESEND seconds (after) is sent again (C++ Client::kResendAfter,
-- kQuietResend; Python RESEND_AFTER, QUIET_RESEND; Java RESEND_AFTER_MS, QUIET_RESEND_MS).
M.RESEND_AFTER = 0.5
M.QUIET_RESEND = 1.0
-- Seconds a request waits for its terminal reply by default, the same in every client (C++
-- Client::kRequestTimeout, Java MotionClient.REQUEST_TIMEOUT_MS, Python REQUEST_TIMEOUT).
M.REQUEST_TIMEOUT = 60
-- Reply error code of a request the coordinator's security refused (C++ ReplyError::kUnauthorized).
M.UNAUTHORIZED = 19

M.kinds = {
  move_absolute = request_t.MOVE_ABSOLUTE, move_relative = request_t.MOVE_RELATIVE, jog = request_t.JOG,
  stop = request_t.STOP, estop = request_t.ESTOP, home = request_t.HOME, enable = request_t.ENABLE,
  disable = request_t.DISABLE, fault_reset = request_t.FAULT_RESET, set_outputs = request_t.SET_OUTPUTS,
  param_read = request_t.PARAM_READ, param_write = request_t.PARAM_WRITE, set_position = request_t.SET_POSITION,
}

local status_names = {
  [reply_t.ACCEPTED] = "accepted", [reply_t.STARTED] = "started", [reply_t.PROGRESS] = "progress",
  [reply_t.DONE] = "done", [reply_t.REJECTED] = "rejected", [reply_t.ABORTED] = "aborted", [reply_t.FAILED] = "failed",
}
M.health_states = {
  [health_t.STARTING] = "STARTING", [health_t.OK] = "OK", [health_t.DEGRADED] = "DEGRADED",
  [health_t.FAULT] = "FAULT", [health_t.STOPPING] = "STOPPING",
}

function M.is_terminal(status)
  return status == reply_t.DONE or status == reply_t.REJECTED or status == reply_t.ABORTED or status == reply_t.FAILED
end

function M.status_name(status)
  return status_names[status] or "unknown"
end

-- request_t kind from its number or name ("move_absolute", "ENABLE", "move-relative").
function M.kind_value(kind)
  if type(kind) == "number" then return kind end
  local k = M.kinds[string.lower(tostring(kind)):gsub("-", "_")]
  if not k then error("unknown request kind '" .. tostring(kind) .. "'", 2) end
  return k
end

local function new_param()
  local p = param_t:new()
  p.mnemonic = ""
  return p
end

local Client = {}
Client.__index = Client

-- opts: url (nil = $LCM_DEFAULT_URL, then LCM's default), prefix ("MOTION_"), client_id, key (sign with it).
-- Raises an error when LCM cannot be opened.
function M.new(opts)
  opts = opts or {}
  local self = setmetatable({}, Client)
  self.url = opts.url or os.getenv("LCM_DEFAULT_URL") or ""
  self.lc = (self.url ~= "") and lcm.lcm.new(self.url) or lcm.lcm.new()
  self.prefix = opts.prefix or "MOTION_"
  self.id = opts.client_id or ("lua:" .. tostring(os.time()) .. ":" .. tostring(math.random(1, 1000000)))
  -- Request ids start at the wall clock (microseconds; exact in a double) so a restarted client
  -- never reuses a live id.
  self.next_request_id = os.time() * 1000000
  -- Pending requests by id: {handler = on_reply or false, label = " request <id> of client '<id>'"
  -- (how a SECURITY event names it), msg = the request_t as sent, last_heard = now() when it was
  -- last sent or answered, heard = a reply came}.
  self.pending = {}
  self.resent = 0  -- requests sent again so far (follow)
  self.axes = {}
  self.beats = {}
  self.lc:subscribe(self.prefix .. "REPLY", function(_, data) self:_on_reply(data) end)
  self.lc:subscribe(self.prefix .. "AXIS_STATE", function(_, data) self:_on_axis_state(data) end)
  self.lc:subscribe(self.prefix .. "EVENT", function(_, data) self:_on_event(data) end)
  self.lc:subscribe(self.prefix .. "HEALTH", function(_, data) self:_on_health(data) end)
  if opts.key then self:sign_with(opts.key) end
  return self
end

-- Signs every request from now on with `key` (motionsigning.load_private_key); the client id
-- becomes the key's own ("<name>/<id>"), as the coordinator requires.
function Client:sign_with(key)
  self.signer = require("motionsigning").request_signer(key, self.prefix)
  self.id = self.signer:own_client_id(self.id)
end

-- From now on only replies and SECURITY events signed by the coordinator count (see above);
-- coordinator: its 32-byte public key (a byte string); window_ms: security.window_ms (2000).
function Client:verify_with(coordinator, window_ms)
  local signing = require("motionsigning")
  local subscribed = self.reply_verifier ~= nil
  self.reply_verifier = signing.message_verifier(coordinator, self.prefix, "REPLY", window_ms)
  self.event_verifier = signing.message_verifier(coordinator, self.prefix, "EVENT", window_ms)
  self.forged_replies = self.forged_replies or 0
  if subscribed then return end
  self.lc:subscribe(self.prefix .. "SREPLY", function(_, data) self:_on_signed_reply(data) end)
  self.lc:subscribe(self.prefix .. "SEVENT", function(_, data) self:_on_signed_event(data) end)
end

-- From now on axis_states() and on_axis_state() take only states signed by one of `gateways`
-- (motionsigning.load_gateway_keys of security.authorized_keys) for a bus it may vouch for (see
-- above); window_ms: security.window_ms (2000). Forgets the states taken unverified so far.
function Client:verify_states_with(gateways, window_ms)
  local signing = require("motionsigning")
  local subscribed = self.state_verifier ~= nil
  self.state_verifier = signing.message_verifier(gateways, self.prefix, "AXIS_STATE", window_ms, nil, "a gateway key")
  self.forged_states = self.forged_states or 0
  self.axes = {}
  if subscribed then return end
  self.lc:subscribe(self.prefix .. "SAXIS_STATE", function(_, data) self:_on_signed_axis_state(data) end)
end

-- Whether axis states are taken only signed by a gateway key (verify_states_with).
function Client:states_verified() return self.state_verifier ~= nil end

-- Publishes a request; every reply goes to on_reply(reply). fields: velocity_scale,
-- acceleration_scale, timeout_ms, output_mask, output_value, param. Returns the request id.
function Client:send(kind, axes, values, on_reply, fields)
  local msg = request_t:new()
  msg.utime = os.time() * 1000000
  msg.client_id = self.id
  msg.request_id = self.next_request_id
  self.next_request_id = self.next_request_id + 1
  msg.kind = M.kind_value(kind)
  msg.axes = {}
  msg.values = {}
  for i, a in ipairs(axes or {}) do
    msg.axes[i] = a
    msg.values[i] = (values and values[i]) or 0.0
  end
  msg.num_axes = #msg.axes
  msg.param = new_param()
  for k, v in pairs(fields or {}) do
    if k ~= "velocity_scale" and k ~= "acceleration_scale" and k ~= "timeout_ms" and k ~= "output_mask"
        and k ~= "output_value" and k ~= "param" then
      error("unknown request field '" .. tostring(k) .. "'", 2)
    end
    msg[k] = v
  end
  local p = {handler = on_reply or false, msg = msg, heard = false,
             label = string.format(" request %.0f of client '%s'", msg.request_id, msg.client_id)}
  self.pending[msg.request_id] = p
  self:_publish(p)
  return msg.request_id
end

-- Publishes a pending request (again) with a new send time, signed when signing.
function Client:_publish(p)
  local msg = p.msg
  p.last_heard = now()
  if self.signer then
    -- os.time()'s whole seconds would repeat counters across runs within a second.
    msg.utime = require("motionsigning").now_us()
    self.lc:publish(self.prefix .. "SREQUEST", self.signer:sign(msg, msg.utime):encode())
  else
    msg.utime = os.time() * 1000000
    self.lc:publish(self.prefix .. "REQUEST", msg:encode())
  end
end

-- Pumps LCM until done() or the deadline (a now() value); false then.
function Client:_wait_until(done, deadline)
  while not done() do
    if now() >= deadline then return false end
    self.lc:handle_timeout(50)
  end
  return true
end

-- _wait_until(), sending request `id` again while it is pending and nothing has been heard of it
-- for M.RESEND_AFTER (before its first reply) or M.QUIET_RESEND seconds (after). Never at or after
-- the deadline: a copy sent then could not be answered in time.
function Client:_follow(id, done, deadline)
  return self:_wait_until(function()
    if done() then return true end
    local p = self.pending[id]
    local t = now()
    if p and t < deadline and t - p.last_heard >= (p.heard and M.QUIET_RESEND or M.RESEND_AFTER) then
      self.resent = self.resent + 1
      self:_publish(p)
    end
    return false
  end, deadline)
end

-- wait_until(), sending request `id` (of send()) again while nothing is heard of it (see "Lost
-- datagrams" above). False on timeout.
function Client:follow(id, done, timeout)
  return self:_follow(id, done, deadline_after(timeout))
end

-- Sends and waits for the terminal reply (a motionlcm reply_t table). When none comes within
-- opts.timeout seconds (default M.REQUEST_TIMEOUT), returns a local FAILED reply saying so. opts.on_progress(reply)
-- gets the non-terminal replies. Other opts are request fields (see send).
function Client:request(kind, axes, values, opts)
  opts = opts or {}
  local timeout = opts.timeout or M.REQUEST_TIMEOUT
  local fields = {}
  for k, v in pairs(opts) do
    if k ~= "timeout" and k ~= "on_progress" then fields[k] = v end
  end
  local result
  local answered = false
  -- Both waits are measured from before the first send, so silence ends with the sends of
  -- ACCEPT_TIMEOUT / RESEND_AFTER (4), not one more just before the end.
  local start = now()
  local id = self:send(kind, axes, values, function(r)
    answered = true
    if M.is_terminal(r.status) then
      result = r
    elseif opts.on_progress then
      opts.on_progress(r)
    end
  end, fields)
  -- The coordinator answers every request at once (ACCEPTED or REJECTED): silence within
  -- M.ACCEPT_TIMEOUT means nobody listens, and the caller learns it then.
  local first_wait = math.min(timeout, M.ACCEPT_TIMEOUT)
  local deadline = clock and start or os.time() + 1  -- whole seconds: never earlier than asked
  local heard = self:_follow(id, function() return answered end, deadline + first_wait)
  if not heard or not self:_follow(id, function() return result ~= nil end, deadline + timeout) then
    self.pending[id] = nil
    result = reply_t:new()
    result.utime = os.time() * 1000000
    result.client_id = self.id
    result.request_id = id
    result.status = reply_t.FAILED
    local where = string.format("%s, channel %s%s", self.url ~= "" and self.url or "the default LCM URL", self.prefix,
                                self.signer and "SREQUEST" or "REQUEST")
    if heard then
      result.reason = string.format("no terminal reply from the coordinator within %d ms (%s)", math.floor(timeout * 1000), where)
    else
      result.reason = string.format("no reply from the coordinator within %d ms: is motion-coordinator running on %s?",
                                    math.floor(first_wait * 1000), where)
    end
    result.error_code = 13  -- timeout
    result.num_axes = 0
    result.axes, result.targets, result.positions, result.start_utime = {}, {}, {}, {}
    result.param = new_param()
  end
  return result
end

function Client:enable(axes, opts) return self:request(request_t.ENABLE, axes, nil, opts) end
function Client:disable(axes, opts) return self:request(request_t.DISABLE, axes, nil, opts) end
function Client:stop(axes, opts) return self:request(request_t.STOP, axes, nil, opts) end

-- Synchronized move: axes = {"x", "y"}, targets = {10, 5} (user units); opts.relative for distances.
function Client:move(axes, targets, opts)
  opts = opts or {}
  local kind = opts.relative and request_t.MOVE_RELATIVE or request_t.MOVE_ABSOLUTE
  local o = {}
  for k, v in pairs(opts) do if k ~= "relative" then o[k] = v end end
  return self:request(kind, axes, targets, o)
end

-- Latest state of every axis heard so far, by axis name (a copy).
function Client:axis_states()
  local copy = {}
  for k, v in pairs(self.axes) do copy[k] = v end
  return copy
end

-- Latest heartbeat of every process heard so far, by process name (a copy).
function Client:heartbeats()
  local copy = {}
  for k, v in pairs(self.beats) do copy[k] = v end
  return copy
end

function Client:on_axis_state(fn) self.state_handler = fn end
function Client:on_event(fn) self.event_handler = fn end
function Client:on_health(fn) self.health_handler = fn end

-- Handles LCM messages for up to `ms` milliseconds (one batch); true when one was handled.
function Client:handle(ms)
  return self.lc:handle_timeout(ms or 100)
end

-- Pumps LCM until done() or the timeout (seconds); false on timeout.
function Client:wait_until(done, timeout)
  return self:_wait_until(done, deadline_after(timeout))
end

function Client:wait_for_heartbeat(process, timeout)
  if self:wait_until(function() return self.beats[process] ~= nil end, timeout or 10) then
    return self.beats[process]
  end
  return nil
end

local function decode(t, data)
  local ok, msg = pcall(t.decode, data)
  if ok then return msg end
  return nil  -- wrong fingerprint or truncated: not ours to crash on
end

function Client:_on_reply(data)
  if self.reply_verifier then return end  -- only the signed twin (SREPLY) counts
  self:_take_reply(decode(reply_t, data))
end

-- A reply for a request no longer pending (a repeat of its terminal reply, answering a copy sent
-- again) is dropped: each request ends in exactly one terminal reply.
function Client:_take_reply(r)
  if not r or r.client_id ~= self.id then return end
  local p = self.pending[r.request_id]
  if p == nil then return end
  p.heard, p.last_heard = true, now()
  if M.is_terminal(r.status) then self.pending[r.request_id] = nil end
  if p.handler then p.handler(r) end
end

local signed_message_t
local function signed_message(data)
  signed_message_t = signed_message_t or require("motionlcm.signed_message_t")
  return decode(signed_message_t, data)
end

function Client:_on_signed_reply(data)
  local e = signed_message(data)
  if not e then return end
  local signing = require("motionsigning")
  local message, why = self.reply_verifier:verify(e, signing.now_us())
  if message then return self:_take_reply(decode(reply_t, message)) end
  local claimed = decode(reply_t, signing.bytes_of(e.message))
  if claimed and claimed.client_id == self.id and self.pending[claimed.request_id] ~= nil then
    self.forged_replies = self.forged_replies + 1
    if self.forged_replies <= 10 then
      io.stderr:write(string.format("motionclient: ignored a reply to request %.0f: %s\n", claimed.request_id, why))
    end
  end
end

function Client:_on_signed_event(data)
  local e = signed_message(data)
  if not e then return end
  local message = self.event_verifier:verify(e, require("motionsigning").now_us())
  local event = message and decode(event_t, message)
  if event and event.kind == event_t.SECURITY then self:_on_security_event(event) end
end

-- The coordinator refused a request of ours without a reply (its ids could not be trusted): end
-- it now with a local REJECTED (code 19) carrying the event's text, as the C++ client does.
function Client:_on_security_event(e)
  local refused = {}
  for id, p in pairs(self.pending) do
    if e.text:find(p.label, 1, true) then refused[#refused + 1] = id end
  end
  for _, id in ipairs(refused) do
    local handler = self.pending[id].handler
    self.pending[id] = nil
    local r = reply_t:new()
    r.utime = e.utime
    r.client_id = self.id
    r.request_id = id
    r.status = reply_t.REJECTED
    r.error_code = M.UNAUTHORIZED
    r.reason = "refused by the coordinator's security (SECURITY event, no reply): " .. e.text
    r.num_axes = 0
    r.axes, r.targets, r.positions, r.start_utime = {}, {}, {}, {}
    r.param = new_param()
    if handler then handler(r) end
  end
end

function Client:_on_axis_state(data)
  if self.state_verifier then return end  -- only the signed copies (SAXIS_STATE) count
  local s = decode(axis_state_t, data)
  if s then self:_take_state(s) end
end

function Client:_on_signed_axis_state(data)
  local e = signed_message(data)
  if not e then return end
  local s, why = self.state_verifier:verify_message(e, require("motionsigning").now_us(), axis_state_t,
                                                    function(m) return m.bus end)
  if s then return self:_take_state(s) end
  self.forged_states = self.forged_states + 1
  if self.forged_states <= 10 then io.stderr:write("motionclient: SECURITY: an axis state is ignored: " .. why .. "\n") end
end

function Client:_take_state(s)
  self.axes[s.axis] = s
  if self.state_handler then self.state_handler(s) end
end

function Client:_on_event(data)
  local e = decode(event_t, data)
  if not e then return end
  if e.kind == event_t.SECURITY and not self.event_verifier then self:_on_security_event(e) end
  if self.event_handler then self.event_handler(e) end
end

function Client:_on_health(data)
  local h = decode(health_t, data)
  if not h then return end
  self.beats[h.process] = h
  if self.health_handler then self.health_handler(h) end
end

-- Shared by the example programs: "--name value", "--name=value", "--axes x y". Returns a table
-- name -> list of values, or nil and an error message.
function M.parse_args(argv, arity)
  local out, i = {}, 1
  while i <= #argv do
    local a = argv[i]
    local name, inline = a:match("^(%-%-[%w-]+)=(.*)$")
    name = name or a
    local n = arity[name]
    if not n then return nil, "unknown option " .. a end
    local vals = {}
    if inline then vals[1] = inline end
    while #vals < n do
      i = i + 1
      if i > #argv then return nil, name .. " needs " .. n .. " value(s)" end
      vals[#vals + 1] = argv[i]
    end
    out[name] = vals
    i = i + 1
  end
  return out
end

return M
