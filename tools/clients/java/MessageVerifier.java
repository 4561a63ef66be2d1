// The coordinator's signed messages in the Java client (README "Security"), as the C++
// security::MessageVerifier and Python's motionclient.signing.MessageVerifier: a verifier listens
// for one channel (e.g. "REPLY", whose signed copies come on <prefix>SREPLY) and takes a
// signed_message_t when, in this order, its channel is that one, its key id is the coordinator's
// (or, for what several signers publish, e.g. gateways' AXIS_STATE, one of theirs), the Ed25519
// signature (the JDK's own, java.security "Ed25519") over Signing.messageSignedBytes verifies,
// utime is within the window of the receiver's clock and not before the verifier was made, and the
// counter is above the last one it accepted from that key (a replay otherwise). verify() returns
// the message's bytes, or null with reason() saying which check failed. verifyMessage() decodes
// the message and keeps the counter per key and bus, and a gateway key bound to buses
// (authorized_keys buses=) vouches only for a message of one of its buses.
//
// Thread contract: verify() is synchronized (LCM's receive thread calls it; the counter is state).
import java.security.GeneralSecurityException;
import java.security.PublicKey;
import java.security.Signature;
import java.util.Arrays;
import java.util.HashMap;
import java.util.List;
import java.util.Map;
import java.util.function.Function;

import motionlcm.signed_message_t;

public final class MessageVerifier {
    /** Decodes a message's LCM bytes (e.g. axis_state_t::new). */
    public interface Decoder<T> { T decode(byte[] bytes) throws java.io.IOException; }

    private static final class Signer {
        final byte[] keyId;
        final PublicKey key;
        final GatewayKeys.Key gateway;  // null: the coordinator's key

        Signer(byte[] raw, GatewayKeys.Key gateway) throws GeneralSecurityException {
            this.keyId = Arrays.copyOf(raw, Signing.KEY_ID_BYTES);
            this.key = Signing.publicKey(raw);
            this.gateway = gateway;
        }
    }

    private final Signer[] signers;
    private final String signersAre;
    private final String prefix;
    private final String channel;
    private final long windowUs;
    private final long notBeforeUs;
    private final Map<String, Long> lastCounter = new HashMap<>();  // per "<key id>/<bus>"
    private String reason = "";

    /** coordinator: its raw 32-byte public key (Signing.loadPublicKey of security.coordinator_public_key). */
    public MessageVerifier(byte[] coordinator, String prefix, String channel, long windowMs, long notBeforeUs) throws GeneralSecurityException {
        this(new Signer[] {new Signer(coordinator, null)}, "the coordinator's (" + hex(Arrays.copyOf(coordinator, Signing.KEY_ID_BYTES)) + ")",
             prefix, channel, windowMs, notBeforeUs);
    }

    /** The verifier of a client starting now: nothing signed before it counts. */
    public MessageVerifier(byte[] coordinator, String prefix, String channel, long windowMs) throws GeneralSecurityException {
        this(coordinator, prefix, channel, windowMs, System.currentTimeMillis() * 1000);
    }

    /** What any of `gateways` signs (GatewayKeys.load); signersAre names them in a refusal ("a gateway key"). */
    public MessageVerifier(List<GatewayKeys.Key> gateways, String signersAre, String prefix, String channel, long windowMs, long notBeforeUs)
            throws GeneralSecurityException {
        this(signersOf(gateways), signersAre, prefix, channel, windowMs, notBeforeUs);
    }

    private MessageVerifier(Signer[] signers, String signersAre, String prefix, String channel, long windowMs, long notBeforeUs) {
        this.signers = signers;
        this.signersAre = signersAre;
        this.prefix = prefix;
        this.channel = channel;
        this.windowUs = windowMs * 1000;
        this.notBeforeUs = notBeforeUs;
    }

    private static Signer[] signersOf(List<GatewayKeys.Key> gateways) throws GeneralSecurityException {
        Signer[] out = new Signer[gateways.size()];
        for (int i = 0; i < out.length; i++) out[i] = new Signer(gateways.get(i).publicKey, gateways.get(i));
        return out;
    }

    public String channel() { return channel; }

    /** Why the last verify() returned null. */
    public synchronized String reason() { return reason; }

    /** The message's LCM bytes when `e` is the coordinator's, fresh at nowUs (µs since the epoch) and new; else null. */
    public synchronized byte[] verify(signed_message_t e, long nowUs) {
        Signer signer = check(e, nowUs);
        if (signer == null || !takeCounter(signer, "", e.counter)) return null;
        reason = "";
        return e.message.clone();
    }

    /** The message decoded when it verifies (see verify()), with the counter kept per key and
     *  busOf(message), and a gateway key bound to buses taken only for a message of one of them
     *  (checked before the counter, which a refused message leaves as it was); else null. */
    public synchronized <T> T verifyMessage(signed_message_t e, long nowUs, Decoder<T> decoder, Function<T, String> busOf) {
        Signer signer = check(e, nowUs);
        if (signer == null) return null;
        T message;
        try {
            message = decoder.decode(e.message);
        } catch (java.io.IOException | RuntimeException ex) {
            refuse("signed " + channel + " refused: malformed message: " + ex.getMessage());
            return null;
        }
        String bus = busOf.apply(message);
        if (signer.gateway != null && !signer.gateway.vouchesFor(bus)) {
            refuse("signed " + channel + " refused: key " + hex(signer.keyId) + " ('" + signer.gateway.name + "') may vouch only for bus "
                   + String.join(",", signer.gateway.buses) + ", not for bus " + bus.substring(0, Math.min(64, bus.length())));
            return null;
        }
        if (!takeCounter(signer, bus, e.counter)) return null;
        reason = "";
        return message;
    }

    // Channel, signer, signature and freshness: the signer when they pass, else null (reason set).
    private Signer check(signed_message_t e, long nowUs) {
        String what = "signed " + channel + " refused: ";
        if (e.channel == null || !e.channel.equals(channel)) {
            String c = e.channel == null ? "" : e.channel;
            return refuse(what + "it was signed for channel '" + c.substring(0, Math.min(64, c.length())) + "'");
        }
        Signer signer = null;
        for (Signer s : signers) if (e.key_id != null && Arrays.equals(e.key_id, s.keyId)) signer = s;
        if (signer == null) return refuse(what + "key " + hex(e.key_id) + " is not " + signersAre);
        if (e.message == null || e.message.length != e.message_size || !signatureVerifies(signer, e)) {
            return refuse(what + "bad signature (forged or altered in transit)");
        }
        if (e.utime < notBeforeUs) return refuse(what + "stale timestamp: signed before this client started (a replay?)");
        if (Math.abs(nowUs - e.utime) > windowUs) {
            return refuse(what + "stale timestamp: signed " + Math.abs(nowUs - e.utime) / 1000 + " ms " + (nowUs >= e.utime ? "ago" : "in the future")
                          + ", outside the window of " + windowUs / 1000 + " ms (clocks out of sync, or a replay)");
        }
        return signer;
    }

    private boolean takeCounter(Signer signer, String bus, long counter) {
        String stream = hex(signer.keyId) + "/" + bus;
        long last = lastCounter.getOrDefault(stream, 0L);
        if (counter <= last) {
            refuse("signed " + channel + " refused: replayed counter " + counter + " (last accepted " + last
                   + (bus.isEmpty() ? "" : " for " + bus.substring(0, Math.min(64, bus.length()))) + ")");
            return false;
        }
        lastCounter.put(stream, counter);
        return true;
    }

    private boolean signatureVerifies(Signer signer, signed_message_t e) {
        try {
            Signature s = Signature.getInstance("Ed25519");
            s.initVerify(signer.key);
            s.update(Signing.messageSignedBytes(prefix, channel, e.key_id, e.counter, e.utime, e.message));
            return e.signature != null && s.verify(e.signature);
        } catch (GeneralSecurityException ex) {  // a malformed signature: not the signer's
            return false;
        }
    }

    private Signer refuse(String why) {
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
