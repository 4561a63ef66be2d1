// The coordinator's signed messages in the Java client (README "Security"), as the C++
// security::MessageVerifier and Python's motionclient.signing.MessageVerifier: a verifier listens
// for one channel (e.g. "REPLY", whose signed copies come on <prefix>SREPLY) and takes a
// signed_message_t when, in this order, its channel is that one, its key id is the coordinator's,
// the Ed25519 signature (the JDK's own, java.security "Ed25519") over Signing.messageSignedBytes
// verifies, utime is within the window of the receiver's clock and not before the verifier was
// made, and the counter is above the last one it accepted (a replay otherwise). verify() returns
// the message's bytes, or null with reason() saying which check failed.
//
// Thread contract: verify() is synchronized (LCM's receive thread calls it; the counter is state).
import java.security.GeneralSecurityException;
import java.security.PublicKey;
import java.security.Signature;
import java.util.Arrays;

import motionlcm.signed_message_t;

public final class MessageVerifier {
    private final PublicKey coordinator;
    private final byte[] keyId;
    private final String prefix;
    private final String channel;
    private final long windowUs;
    private final long notBeforeUs;
    private long lastCounter = 0;
    private String reason = "";

    /** coordinator: its raw 32-byte public key (Signing.loadPublicKey of security.coordinator_public_key). */
    public MessageVerifier(byte[] coordinator, String prefix, String channel, long windowMs, long notBeforeUs) throws GeneralSecurityException {
        this.coordinator = Signing.publicKey(coordinator);
        this.keyId = Arrays.copyOf(coordinator, Signing.KEY_ID_BYTES);
        this.prefix = prefix;
        this.channel = channel;
        this.windowUs = windowMs * 1000;
        this.notBeforeUs = notBeforeUs;
    }

    /** The verifier of a client starting now: nothing signed before it counts. */
    public MessageVerifier(byte[] coordinator, String prefix, String channel, long windowMs) throws GeneralSecurityException {
        this(coordinator, prefix, channel, windowMs, System.currentTimeMillis() * 1000);
    }

    public String channel() { return channel; }

    /** Why the last verify() returned null. */
    public synchronized String reason() { return reason; }

    /** The message's LCM bytes when `e` is the coordinator's, fresh at nowUs (µs since the epoch) and new; else null. */
    public synchronized byte[] verify(signed_message_t e, long nowUs) {
        String what = "signed " + channel + " refused: ";
        if (e.channel == null || !e.channel.equals(channel)) {
            String c = e.channel == null ? "" : e.channel;
            return refuse(what + "it was signed for channel '" + c.substring(0, Math.min(64, c.length())) + "'");
        }
        if (e.key_id == null || !Arrays.equals(e.key_id, keyId)) {
            return refuse(what + "key " + hex(e.key_id) + " is not the coordinator's (" + hex(keyId) + ")");
        }
        if (e.message == null || e.message.length != e.message_size || !signatureVerifies(e)) {
            return refuse(what + "bad signature (forged or altered in transit)");
        }
        if (e.utime < notBeforeUs) return refuse(what + "stale timestamp: signed before this client started (a replay?)");
        if (Math.abs(nowUs - e.utime) > windowUs) {
            return refuse(what + "stale timestamp: signed " + Math.abs(nowUs - e.utime) / 1000 + " ms " + (nowUs >= e.utime ? "ago" : "in the future")
                          + ", outside the window of " + windowUs / 1000 + " ms (clocks out of sync, or a replay)");
        }
        if (e.counter <= lastCounter) return refuse(what + "replayed counter " + e.counter + " (last accepted " + lastCounter + ")");
        lastCounter = e.counter;
        reason = "";
        return e.message.clone();
    }

    private boolean signatureVerifies(signed_message_t e) {
        try {
            Signature s = Signature.getInstance("Ed25519");
            s.initVerify(coordinator);
            s.update(Signing.messageSignedBytes(prefix, channel, e.key_id, e.counter, e.utime, e.message));
            return e.signature != null && s.verify(e.signature);
        } catch (GeneralSecurityException ex) {  // a malformed signature: not the coordinator's
            return false;
        }
    }

    private byte[] refuse(String why) {
        reason = why;
        return null;
    }

    static String hex(byte[] bytes) {
        if (bytes == null) return "";
        StringBuilder b = new StringBuilder();
        for (byte x : bytes) b.append(String.format("%02x", x & 0xff));
        return b.toString();
    }
}
