// Java client of the motion system, on Debian's lcm.jar and our types jar (motionlcm.jar):
// requests and their terminal replies, axis state, events, heartbeats. Mirrors the C++ client
// (services/client): every request gets replies on REPLY that end in exactly one terminal status
// (DONE, REJECTED, ABORTED, FAILED); request() waits for it.
//
//   try (MotionClient c = new MotionClient("udpm://239.255.76.67:7667?ttl=0", "MOTION_", "my-tool")) {
//       reply_t r = c.request(request_t.ENABLE, new String[] {"x", "y"}, null, 10000);
//   }
//
// Signing (README "Security"): after signWith(key) (Signing.loadPrivateKey) every request goes out
// signed on SREQUEST, byte-identical to the C++ client. A SECURITY event of the coordinator naming
// a pending request (unsigned, unknown key, bad signature...: the coordinator sends no reply) ends it
// at once with a local REJECTED, code 19 (unauthorized).
//
// Verified replies: after verifyWith(coordinatorPublicKey) (Signing.loadPublicKey of
// security.coordinator_public_key) only the coordinator's signed replies and SECURITY events count
// (signed_message_t on SREPLY, SEVENT; MessageVerifier), as in the C++ and Python clients: a plain
// REPLY is ignored (the coordinator's own come signed too), and a signed one that does not verify
// (another key, altered, stale, replayed) is a forgery: the request goes on waiting and
// forgedReplies() counts it.
//
// Verified axis states: after verifyStatesWith(GatewayKeys.load(authorized_keys)) axisStates() and
// onAxisState() take only states signed by a key of role gateway (signed_message_t on SAXIS_STATE;
// channel, key, signature, window, counter per key and bus, a key bound to buses only for those),
// as in the C++ client: plain AXIS_STATEs are ignored and signed ones that do not verify are counted
// (forgedStates()). Without it the plain states are taken, unverified (statesVerified() is false:
// say so where they are shown).
//
// Lost datagrams (README "Safety and faults"): LCM delivers nothing for sure. While request() or
// follow() waits on a request, the request is sent again, unchanged but for its send time (and
// signature), whenever nothing has been heard of it for RESEND_AFTER_MS (before its first reply) or
// QUIET_RESEND_MS (after), as the C++ and Python clients do: the coordinator answers a request sent
// again with its latest reply to it, word for word, and runs nothing twice. A reply heard again
// after the terminal one is not passed on: each request ends in exactly one terminal reply.
//
// Thread contract: thread-safe. LCM delivers messages on its own receive thread: reply, axis-state,
// event and health callbacks run there (keep them short); request() and follow() block the calling
// thread (which sends the request again).
// Run with -Djava.net.preferIPv4Stack=true (LCM multicast is IPv4).
import java.io.IOException;
import java.security.GeneralSecurityException;
import java.util.Collections;
import java.util.HashMap;
import java.util.LinkedHashMap;
import java.util.Map;
import java.util.concurrent.CompletableFuture;
import java.util.concurrent.ConcurrentHashMap;
import java.util.concurrent.ExecutionException;
import java.util.concurrent.Future;
import java.util.concurrent.TimeUnit;
import java.util.concurrent.TimeoutException;
import java.util.concurrent.atomic.AtomicLong;
import java.util.function.Consumer;

import lcm.lcm.LCM;
import lcm.lcm.LCMDataInputStream;
import lcm.lcm.LCMSubscriber;
import motionlcm.axis_state_t;
import motionlcm.event_t;
import motionlcm.health_t;
import motionlcm.param_t;
import motionlcm.reply_t;
import motionlcm.request_t;
import motionlcm.signed_message_t;

public class MotionClient implements AutoCloseable {
    static {
        if (System.getProperty("java.net.preferIPv4Stack") == null) System.setProperty("java.net.preferIPv4Stack", "true");
    }

    /** A request ended in a terminal status other than DONE (thrown by requestOrThrow). */
    public static class RequestFailed extends Exception {
        private static final long serialVersionUID = 1L;
        public final reply_t reply;

        public RequestFailed(reply_t reply) {
            super(statusName(reply.status) + " (error " + reply.error_code + "): " + reply.reason);
            this.reply = reply;
        }
    }

    public static boolean isTerminal(byte status) {
        return status == reply_t.DONE || status == reply_t.REJECTED || status == reply_t.ABORTED || status == reply_t.FAILED;
    }

    public static String statusName(byte status) {
        switch (status) {
            case reply_t.ACCEPTED: return "accepted";
            case reply_t.STARTED: return "started";
            case reply_t.PROGRESS: return "progress";
            case reply_t.DONE: return "done";
            case reply_t.REJECTED: return "rejected";
            case reply_t.ABORTED: return "aborted";
            case reply_t.FAILED: return "failed";
            default: return "unknown";
        }
    }

    public static String healthStateName(byte state) {
        switch (state) {
            case health_t.STARTING: return "STARTING";
            case health_t.OK: return "OK";
            case health_t.DEGRADED: return "DEGRADED";
            case health_t.FAULT: return "FAULT";
            case health_t.STOPPING: return "STOPPING";
            default: return Byte.toString(state);
        }
    }

    private final LCM lcm;
    private final String url;
    /** Reply error code of a request the coordinator's security refused (C++ ReplyError::kUnauthorized). */
    public static final int UNAUTHORIZED = 19;
    /** No reply at all within this many ms means no coordinator is listening (C++: kAcceptTimeout). */
    public static final long ACCEPT_TIMEOUT_MS = 2000;
    /** Milliseconds a request waits for its terminal reply unless told otherwise: the same in every
     *  client (C++ Client::kRequestTimeout, Python REQUEST_TIMEOUT, Lua REQUEST_TIMEOUT). */
    public static final long REQUEST_TIMEOUT_MS = 60000;
    /** Lost datagrams: a pending request of which nothing has been heard for RESEND_AFTER_MS (before
     *  its first reply) or QUIET_RESEND_MS (after) is sent again (C++ Client::kResendAfter,
     *  kQuietResend; Python RESEND_AFTER, QUIET_RESEND; Lua RESEND_AFTER, QUIET_RESEND). */
    public static final long RESEND_AFTER_MS = 500;
    public static final long QUIET_RESEND_MS = 1000;
    private final String prefix;
    private volatile String id;
    private volatile Signing.RequestSigner signer;
    /** A request waiting for its terminal reply. */
    private static final class Pending {
        final Consumer<reply_t> handler;
        final String label;  // " request <id> of client '<id>'": how a SECURITY event names it
        final request_t request;  // as sent; only its utime changes when it is sent again
        volatile boolean heard;  // a reply came
        volatile long lastHeardNanos;  // System.nanoTime() when last sent or answered

        Pending(Consumer<reply_t> handler, request_t request) {
            this.handler = handler;
            this.request = request;
            this.label = " request " + request.request_id + " of client '" + request.client_id + "'";
        }
    }

    // Request ids start at the wall clock so a restarted client never reuses a live id.
    private final AtomicLong nextRequestId = new AtomicLong(System.currentTimeMillis() * 1000);
    private final Map<Long, Pending> pending = new ConcurrentHashMap<>();
    private final AtomicLong resent = new AtomicLong();
    private final Map<String, axis_state_t> axes = new ConcurrentHashMap<>();
    private final Map<String, health_t> heartbeats = new HashMap<>();  // guarded by itself
    private volatile Consumer<axis_state_t> stateHandler;
    private volatile Consumer<event_t> eventHandler;
    private volatile Consumer<health_t> healthHandler;
    private volatile MessageVerifier replyVerifier;  // set by verifyWith
    private volatile MessageVerifier eventVerifier;
    private final AtomicLong forgedReplies = new AtomicLong();
    private volatile MessageVerifier stateVerifier;  // set by verifyStatesWith
    private final AtomicLong forgedStates = new AtomicLong();

    /** url: null or "" = $LCM_DEFAULT_URL, then LCM's default. prefix: lcm.channel_prefix ("MOTION_"). */
    public MotionClient(String url, String prefix, String clientId) throws IOException {
        this.url = (url == null || url.isEmpty()) ? (System.getenv("LCM_DEFAULT_URL") != null ? System.getenv("LCM_DEFAULT_URL") : "") : url;
        this.lcm = this.url.isEmpty() ? new LCM() : new LCM(this.url);
        this.prefix = prefix;
        this.id = clientId != null ? clientId : "java:" + ProcessHandle.current().pid();
        lcm.subscribe(channel("REPLY"), new LCMSubscriber() {
            public void messageReceived(LCM l, String ch, LCMDataInputStream ins) { onReply(ins); }
        });
        lcm.subscribe(channel("AXIS_STATE"), new LCMSubscriber() {
            public void messageReceived(LCM l, String ch, LCMDataInputStream ins) { onAxisState(ins); }
        });
        lcm.subscribe(channel("EVENT"), new LCMSubscriber() {
            public void messageReceived(LCM l, String ch, LCMDataInputStream ins) { onEventMessage(ins); }
        });
        lcm.subscribe(channel("HEALTH"), new LCMSubscriber() {
            public void messageReceived(LCM l, String ch, LCMDataInputStream ins) { onHealthMessage(ins); }
        });
    }

    public MotionClient(String url) throws IOException {
        this(url, "MOTION_", null);
    }

    public String id() { return id; }

    /** Signs every request from now on with `key`; the client id becomes the key's own ("<name>/<id>"),
     *  as the coordinator requires. Call before sending. */
    public void signWith(Signing.Key key) {
        Signing.RequestSigner s = new Signing.RequestSigner(key, prefix);
        id = s.ownClientId(id);
        signer = s;
    }

    /** From now on only replies and SECURITY events signed by the coordinator count (see above);
     *  coordinator: its raw public key (Signing.loadPublicKey); windowMs: security.window_ms. */
    public void verifyWith(byte[] coordinator, long windowMs) throws GeneralSecurityException {
        boolean subscribed = replyVerifier != null;
        eventVerifier = new MessageVerifier(coordinator, prefix, "EVENT", windowMs);
        replyVerifier = new MessageVerifier(coordinator, prefix, "REPLY", windowMs);
        if (subscribed) return;
        lcm.subscribe(channel("SREPLY"), new LCMSubscriber() {
            public void messageReceived(LCM l, String ch, LCMDataInputStream ins) { onSignedReply(ins); }
        });
        lcm.subscribe(channel("SEVENT"), new LCMSubscriber() {
            public void messageReceived(LCM l, String ch, LCMDataInputStream ins) { onSignedEvent(ins); }
        });
    }

    public void verifyWith(byte[] coordinator) throws GeneralSecurityException { verifyWith(coordinator, 2000); }

    /** Signed replies for a pending request of this client that did not verify (verifyWith). */
    public long forgedReplies() { return forgedReplies.get(); }

    /** From now on only axis states signed by one of `gateways` (GatewayKeys.load of
     *  security.authorized_keys) for a bus it may vouch for count (see above); windowMs:
     *  security.window_ms. Forgets the states taken unverified so far. */
    public void verifyStatesWith(java.util.List<GatewayKeys.Key> gateways, long windowMs) throws GeneralSecurityException {
        boolean subscribed = stateVerifier != null;
        stateVerifier = new MessageVerifier(gateways, "a gateway key", prefix, "AXIS_STATE", windowMs, System.currentTimeMillis() * 1000);
        axes.clear();
        if (subscribed) return;
        lcm.subscribe(channel("SAXIS_STATE"), new LCMSubscriber() {
            public void messageReceived(LCM l, String ch, LCMDataInputStream ins) { onSignedAxisState(ins); }
        });
    }

    /** Whether axis states are taken only signed by a gateway key (verifyStatesWith). */
    public boolean statesVerified() { return stateVerifier != null; }

    /** Signed axis states that did not verify (forged, altered, replayed, stale, unknown key, wrong bus). */
    public long forgedStates() { return forgedStates.get(); }

    public String url() { return url.isEmpty() ? "the default LCM URL" : url; }
    public String channel(String name) { return prefix + name; }

    // ------------------------------------------------------------------ requests

    /** A request with every field set (strings empty, param present), ready for send(). */
    public static request_t make(byte kind, String[] axisNames, double[] values) {
        request_t r = new request_t();
        r.kind = kind;
        r.client_id = "";
        r.axes = axisNames != null ? axisNames.clone() : new String[0];
        r.num_axes = r.axes.length;
        r.values = new double[r.num_axes];
        if (values != null) System.arraycopy(values, 0, r.values, 0, Math.min(values.length, r.num_axes));
        r.param = new param_t();
        r.param.mnemonic = "";
        return r;
    }

    /** Fills utime/client_id/request_id/num_axes, publishes, and returns the request id; every reply goes to onReply. */
    public long send(request_t request, Consumer<reply_t> onReply) {
        request.utime = System.currentTimeMillis() * 1000;
        request.client_id = id;
        request.request_id = nextRequestId.getAndIncrement();
        if (request.axes == null) request.axes = new String[0];
        request.num_axes = request.axes.length;
        if (request.values == null || request.values.length != request.num_axes) {
            double[] v = new double[request.num_axes];
            if (request.values != null) System.arraycopy(request.values, 0, v, 0, Math.min(v.length, request.values.length));
            request.values = v;
        }
        if (request.param == null) request.param = new param_t();
        if (request.param.mnemonic == null) request.param.mnemonic = "";
        Pending p = new Pending(onReply != null ? onReply : r -> {}, request);
        pending.put(request.request_id, p);
        publish(p);
        return request.request_id;
    }

    /** Requests sent again by request() and follow() so far. */
    public long resent() { return resent.get(); }

    // Publishes a pending request (again) with a new send time, signed when signing.
    private void publish(Pending p) {
        synchronized (p) {
            request_t request = p.request;
            request.utime = System.currentTimeMillis() * 1000;
            p.lastHeardNanos = System.nanoTime();
            Signing.RequestSigner s = signer;
            if (s == null) {
                lcm.publish(channel("REQUEST"), request);
                return;
            }
            try {
                lcm.publish(channel("SREQUEST"), s.sign(request, request.utime));
            } catch (GeneralSecurityException e) {
                forget(request.request_id);
                throw new IllegalStateException("cannot sign with key '" + s.key.name + "': " + e.getMessage(), e);
            }
        }
    }

    /** Waits until `done` completes or timeoutMs pass (false then), sending request `requestId`
     *  (of send()) again while it is pending and nothing has been heard of it (see above). */
    public boolean follow(long requestId, Future<?> done, long timeoutMs) throws InterruptedException {
        return followUntil(requestId, done, System.nanoTime() + TimeUnit.MILLISECONDS.toNanos(timeoutMs));
    }

    // follow() until the System.nanoTime() deadline. Never sends at or after it: a copy sent then
    // could not be answered in time.
    private boolean followUntil(long requestId, Future<?> done, long deadline) throws InterruptedException {
        while (true) {
            long now = System.nanoTime();
            if (done.isDone()) return true;
            if (now - deadline >= 0) return false;
            long wait = deadline - now;
            Pending p = pending.get(requestId);
            if (p != null) {
                // heard read first: takeReply sets lastHeardNanos before it.
                long quiet = TimeUnit.MILLISECONDS.toNanos(p.heard ? QUIET_RESEND_MS : RESEND_AFTER_MS);
                long due = p.lastHeardNanos + quiet;
                if (now - due >= 0) {
                    resent.incrementAndGet();
                    publish(p);
                    continue;
                }
                wait = Math.min(wait, due - now);
            }
            try {
                done.get(wait, TimeUnit.NANOSECONDS);
                return true;
            } catch (TimeoutException e) {
                // a reply may have come meanwhile (lastHeardNanos): look again
            } catch (ExecutionException e) {
                return true;  // completed, exceptionally
            }
        }
    }

    /** Sends and waits for the terminal reply, sending the request again while nothing is heard of
     *  it (see "Lost datagrams" above). When none comes within timeoutMs, returns a local
     *  FAILED reply saying so (the coordinator may be down). onProgress runs on LCM's thread. */
    public reply_t request(request_t request, long timeoutMs, Consumer<reply_t> onProgress) {
        CompletableFuture<reply_t> terminal = new CompletableFuture<>();
        CompletableFuture<Boolean> answered = new CompletableFuture<>();
        // Both waits are measured from before the first send, so silence ends after the sends of
        // ACCEPT_TIMEOUT_MS / RESEND_AFTER_MS (4), not one more just before the end.
        long start = System.nanoTime();
        long requestId = send(request, r -> {
            answered.complete(true);
            if (isTerminal(r.status)) terminal.complete(r);
            else if (onProgress != null) onProgress.accept(r);
        });
        // The coordinator answers every request at once (ACCEPTED or REJECTED): silence within
        // ACCEPT_TIMEOUT_MS means nobody listens, and the caller learns it then.
        long firstWait = Math.min(timeoutMs, ACCEPT_TIMEOUT_MS);
        String where = url() + ", channel " + channel(signer != null ? "SREQUEST" : "REQUEST");
        try {
            if (!followUntil(requestId, answered, start + TimeUnit.MILLISECONDS.toNanos(firstWait))) {
                forget(requestId);
                return localFailure(requestId, "no reply from the coordinator within " + firstWait + " ms: is motion-coordinator running on " + where + "?");
            }
            if (!followUntil(requestId, terminal, start + TimeUnit.MILLISECONDS.toNanos(timeoutMs))) {
                forget(requestId);
                return localFailure(requestId, "no terminal reply from the coordinator within " + timeoutMs + " ms (" + where + ")");
            }
            return terminal.join();
        } catch (InterruptedException e) {
            forget(requestId);
            Thread.currentThread().interrupt();
            return localFailure(requestId, "interrupted while waiting for the coordinator");
        }
    }

    public reply_t request(byte kind, String[] axisNames, double[] values, long timeoutMs) {
        return request(make(kind, axisNames, values), timeoutMs, null);
    }

    /** request() that throws RequestFailed unless the reply is DONE. */
    public reply_t requestOrThrow(request_t request, long timeoutMs, Consumer<reply_t> onProgress) throws RequestFailed {
        reply_t r = request(request, timeoutMs, onProgress);
        if (r.status != reply_t.DONE) throw new RequestFailed(r);
        return r;
    }

    public reply_t enable(long timeoutMs, String... axisNames) { return request(request_t.ENABLE, axisNames, null, timeoutMs); }
    public reply_t disable(long timeoutMs, String... axisNames) { return request(request_t.DISABLE, axisNames, null, timeoutMs); }
    public reply_t stop(long timeoutMs, String... axisNames) { return request(request_t.STOP, axisNames, null, timeoutMs); }

    /** Synchronized move of several axes, targets in user units (insertion order kept). */
    public reply_t move(Map<String, Double> targets, boolean relative, long timeoutMs, Consumer<reply_t> onProgress) {
        Map<String, Double> ordered = new LinkedHashMap<>(targets);
        String[] names = ordered.keySet().toArray(new String[0]);
        double[] values = new double[names.length];
        for (int i = 0; i < names.length; i++) values[i] = ordered.get(names[i]);
        return request(make(relative ? request_t.MOVE_RELATIVE : request_t.MOVE_ABSOLUTE, names, values), timeoutMs, onProgress);
    }

    private reply_t localFailure(long requestId, String reason) {
        reply_t r = new reply_t();
        r.utime = System.currentTimeMillis() * 1000;
        r.client_id = id;
        r.request_id = requestId;
        r.status = reply_t.FAILED;
        r.reason = reason;
        r.error_code = 13;  // timeout
        r.axes = new String[0];
        r.targets = new double[0];
        r.positions = new double[0];
        r.start_utime = new long[0];
        r.param = new param_t();
        r.param.mnemonic = "";
        return r;
    }

    // ------------------------------------------------------------------ state, events, health

    /** Latest state of every axis heard so far (a snapshot). */
    public Map<String, axis_state_t> axisStates() { return Collections.unmodifiableMap(new HashMap<>(axes)); }

    /** Latest heartbeat of every process heard so far, by process name (a snapshot). */
    public Map<String, health_t> heartbeats() {
        synchronized (heartbeats) { return Collections.unmodifiableMap(new HashMap<>(heartbeats)); }
    }

    /** Waits for a heartbeat of `process`; null on timeout. */
    public health_t waitForHeartbeat(String process, long timeoutMs) throws InterruptedException {
        long deadline = System.nanoTime() + TimeUnit.MILLISECONDS.toNanos(timeoutMs);
        synchronized (heartbeats) {
            while (!heartbeats.containsKey(process)) {
                long left = TimeUnit.NANOSECONDS.toMillis(deadline - System.nanoTime());
                if (left <= 0) return null;
                heartbeats.wait(left);
            }
            return heartbeats.get(process);
        }
    }

    public void onAxisState(Consumer<axis_state_t> handler) { stateHandler = handler; }
    public void onEvent(Consumer<event_t> handler) { eventHandler = handler; }
    public void onHealth(Consumer<health_t> handler) { healthHandler = handler; }

    @Override
    public void close() { lcm.close(); }

    // ------------------------------------------------------------------ LCM handlers (LCM's thread)

    private void forget(long requestId) {
        pending.remove(requestId);
    }

    private void onReply(LCMDataInputStream ins) {
        if (replyVerifier != null) return;  // only the signed twin (SREPLY) counts
        try { takeReply(new reply_t(ins)); } catch (IOException e) { return; }  // not a reply_t: ignore
    }

    // A reply for a request no longer pending (a repeat of its terminal reply, answering a copy sent
    // again) is dropped: each request ends in exactly one terminal reply.
    private void takeReply(reply_t r) {
        if (!id.equals(r.client_id)) return;
        Pending p = isTerminal(r.status) ? pending.remove(r.request_id) : pending.get(r.request_id);
        if (p == null) return;
        p.lastHeardNanos = System.nanoTime();
        p.heard = true;
        p.handler.accept(r);
    }

    // A hostile message_size makes the decoder ask for up to 2 GiB at once: that one allocation
    // fails (OutOfMemoryError) and the message is dropped, as a malformed one.
    private static signed_message_t decodeSigned(LCMDataInputStream ins) {
        try { return new signed_message_t(ins); } catch (IOException | RuntimeException | OutOfMemoryError ex) { return null; }
    }

    private void onSignedReply(LCMDataInputStream ins) {
        signed_message_t e = decodeSigned(ins);
        if (e == null) return;
        MessageVerifier v = replyVerifier;
        byte[] message = v.verify(e, System.currentTimeMillis() * 1000);
        if (message != null) {
            try { takeReply(new reply_t(message)); } catch (IOException ex) { return; }
            return;
        }
        long requestId = claimedRequestId(e.message);
        if (requestId < 0 || !pending.containsKey(requestId)) return;
        if (forgedReplies.incrementAndGet() <= 10) {
            System.err.println("MotionClient: ignored a reply to request " + requestId + ": " + v.reason());
        }
    }

    // The request id an unverified reply_t claims when it names this client, else -1; reads only
    // fingerprint, utime, client_id and request_id, within the bytes (nothing sized by them is allocated).
    private long claimedRequestId(byte[] message) {
        if (message == null) return -1;
        java.nio.ByteBuffer b = java.nio.ByteBuffer.wrap(message);  // big-endian, as LCM
        byte[] own = (id + "\0").getBytes(java.nio.charset.StandardCharsets.UTF_8);
        if (b.remaining() < 20 || b.getLong() != reply_t.LCM_FINGERPRINT) return -1;
        b.getLong();  // utime
        int length = b.getInt();
        if (length != own.length || b.remaining() < length + 8) return -1;
        byte[] clientId = new byte[length];
        b.get(clientId);
        return java.util.Arrays.equals(clientId, own) ? b.getLong() : -1;
    }

    private void onSignedEvent(LCMDataInputStream ins) {
        signed_message_t e = decodeSigned(ins);
        if (e == null) return;
        byte[] message = eventVerifier.verify(e, System.currentTimeMillis() * 1000);
        if (message == null) return;
        event_t event;
        try { event = new event_t(message); } catch (IOException ex) { return; }
        if (event.kind == event_t.SECURITY) onSecurityEvent(event);
    }

    // The coordinator refused a request of ours without a reply (its ids could not be trusted): end
    // it now with a local REJECTED (code 19) carrying the event's text, as the C++ client does.
    private void onSecurityEvent(event_t e) {
        for (Map.Entry<Long, Pending> entry : pending.entrySet()) {
            if (!e.text.contains(entry.getValue().label)) continue;
            long requestId = entry.getKey();
            Pending p = pending.remove(requestId);
            if (p == null) continue;
            reply_t r = localFailure(requestId, "refused by the coordinator's security (SECURITY event, no reply): " + e.text);
            r.utime = e.utime;
            r.status = reply_t.REJECTED;
            r.error_code = UNAUTHORIZED;
            p.handler.accept(r);
        }
    }

    private void onAxisState(LCMDataInputStream ins) {
        if (stateVerifier != null) return;  // only the signed copies (SAXIS_STATE) count
        axis_state_t s;
        try { s = new axis_state_t(ins); } catch (IOException e) { return; }
        takeState(s);
    }

    private void onSignedAxisState(LCMDataInputStream ins) {
        signed_message_t e = decodeSigned(ins);
        if (e == null) return;
        MessageVerifier v = stateVerifier;
        axis_state_t s = v.verifyMessage(e, System.currentTimeMillis() * 1000, axis_state_t::new, m -> m.bus);
        if (s != null) {
            takeState(s);
            return;
        }
        if (forgedStates.incrementAndGet() <= 10) System.err.println("MotionClient: SECURITY: an axis state is ignored: " + v.reason());
    }

    private void takeState(axis_state_t s) {
        axes.put(s.axis, s);
        Consumer<axis_state_t> h = stateHandler;
        if (h != null) h.accept(s);
    }

    private void onEventMessage(LCMDataInputStream ins) {
        event_t e;
        try { e = new event_t(ins); } catch (IOException ex) { return; }
        if (e.kind == event_t.SECURITY && eventVerifier == null) onSecurityEvent(e);
        Consumer<event_t> h = eventHandler;
        if (h != null) h.accept(e);
    }

    private void onHealthMessage(LCMDataInputStream ins) {
        health_t hb;
        try { hb = new health_t(ins); } catch (IOException e) { return; }
        synchronized (heartbeats) {
            heartbeats.put(hb.process, hb);
            heartbeats.notifyAll();
        }
        Consumer<health_t> h = healthHandler;
        if (h != null) h.accept(hb);
    }
}
