// Verified replies in the Java client (ctest clients_java_reply_verification):
//  1. the coordinator's signed reply of tests/vectors/signed_reply_v1.txt (the bytes the C++
//     MessageSigner produces) verifies here, byte for byte, and is refused replayed, stale, for
//     another prefix or channel, altered, or under another key;
//  2. a MotionClient after verifyWith(coordinator's key), on its own LCM URL: a plain REPLY, a
//     reply signed with another key, one whose signature was altered and a replayed one do not end
//     its request (forgedReplies() counts the signed ones); the coordinator's signed replies do; a
//     plain SECURITY event naming a pending request does not end it either.
// Prints one line per check; "FAIL ..." for each that failed, "reply verification ok" when all passed.
//   java -cp lcm.jar:motionlcm.jar:classes ReplyVerification tests/vectors/signed_reply_v1.txt
import java.io.ByteArrayOutputStream;
import java.io.DataOutputStream;
import java.io.IOException;
import java.nio.charset.StandardCharsets;
import java.nio.file.Files;
import java.nio.file.Path;
import java.util.ArrayList;
import java.util.HashMap;
import java.util.List;
import java.util.Map;
import java.util.concurrent.LinkedBlockingQueue;
import java.util.concurrent.TimeUnit;

import lcm.lcm.LCM;
import lcm.lcm.LCMEncodable;
import motionlcm.event_t;
import motionlcm.param_t;
import motionlcm.reply_t;
import motionlcm.request_t;
import motionlcm.signed_message_t;

public class ReplyVerification {
    static int failures = 0;

    static void check(String what, Object actual, Object expected) {
        boolean ok = String.valueOf(actual).equals(String.valueOf(expected));
        System.out.println((ok ? "ok   " : "FAIL ") + what + (ok ? "" : ": got " + actual + ", expected " + expected));
        if (!ok) failures++;
    }

    static byte[] unhex(String text) {
        byte[] out = new byte[text.length() / 2];
        for (int i = 0; i < out.length; i++) out[i] = (byte) Integer.parseInt(text.substring(2 * i, 2 * i + 2), 16);
        return out;
    }

    static byte[] encode(LCMEncodable message) throws IOException {
        ByteArrayOutputStream bytes = new ByteArrayOutputStream();
        message.encode(new DataOutputStream(bytes));
        return bytes.toByteArray();
    }

    /** What the coordinator's MessageSigner makes (the vector shows Java's bytes are C++'s). */
    static signed_message_t sign(Signing.Key key, String prefix, String channel, LCMEncodable message, long utime, long counter) throws Exception {
        signed_message_t e = new signed_message_t();
        e.utime = utime;
        e.key_id = key.keyId();
        e.counter = counter;
        e.channel = channel;
        e.message = encode(message);
        e.message_size = e.message.length;
        e.signature = key.sign(Signing.messageSignedBytes(prefix, channel, e.key_id, e.counter, e.utime, e.message));
        return e;
    }

    static void vector(Map<String, String> v, Signing.Key coordinator) throws Exception {
        byte[] pub = unhex(v.get("public_key_hex"));
        check("vector: public key of the key file", MessageVerifier.hex(coordinator.publicKey()), v.get("public_key_hex"));
        signed_message_t e = new signed_message_t(unhex(v.get("envelope_hex")));
        long at = Long.parseLong(v.get("utime"));
        String prefix = v.get("prefix");
        check("vector: signed bytes", MessageVerifier.hex(Signing.messageSignedBytes(prefix, e.channel, e.key_id, e.counter, e.utime, e.message)),
              v.get("signed_bytes_hex"));
        check("vector: Java's signature is C++'s", MessageVerifier.hex(sign(coordinator, prefix, e.channel, new reply_t(e.message), e.utime, e.counter).signature),
              v.get("signature_hex"));
        MessageVerifier verifier = new MessageVerifier(pub, prefix, "REPLY", 2000, at - 1000);
        byte[] message = verifier.verify(e, at + 500);
        check("vector: C++'s signed reply verifies", message == null ? verifier.reason() : MessageVerifier.hex(message), v.get("message_hex"));
        check("vector: the reply inside", message == null ? "" : new reply_t(message).client_id + " " + new reply_t(message).request_id,
              v.get("reply.client_id") + " " + v.get("reply.request_id"));
        check("vector: replayed", verifier.verify(e, at + 600) == null ? verifier.reason() : "accepted",
              "signed REPLY refused: replayed counter " + e.counter + " (last accepted " + e.counter + ")");
        MessageVerifier late = new MessageVerifier(pub, prefix, "REPLY", 2000, 0);
        check("vector: stale", late.verify(e, at + 2_500_000) == null ? late.reason() : "accepted",
              "signed REPLY refused: stale timestamp: signed 2500 ms ago, outside the window of 2000 ms (clocks out of sync, or a replay)");
        MessageVerifier started = new MessageVerifier(pub, prefix, "REPLY", 2000, at + 1);
        check("vector: signed before the client started", started.verify(e, at) == null ? started.reason() : "accepted",
              "signed REPLY refused: stale timestamp: signed before this client started (a replay?)");
        MessageVerifier other = new MessageVerifier(pub, "OTHER_", "REPLY", 2000, 0);
        check("vector: another prefix", other.verify(e, at) == null ? other.reason() : "accepted", "signed REPLY refused: bad signature (forged or altered in transit)");
        MessageVerifier events = new MessageVerifier(pub, prefix, "EVENT", 2000, 0);
        check("vector: another channel", events.verify(e, at) == null ? events.reason() : "accepted", "signed EVENT refused: it was signed for channel 'REPLY'");
        signed_message_t altered = new signed_message_t(unhex(v.get("envelope_hex")));
        altered.message[altered.message.length - 20] ^= 1;
        MessageVerifier fresh = new MessageVerifier(pub, prefix, "REPLY", 2000, 0);
        check("vector: altered", fresh.verify(altered, at) == null ? fresh.reason() : "accepted", "signed REPLY refused: bad signature (forged or altered in transit)");
        Signing.Key stranger = Signing.fromSeed(new byte[32], "stranger");
        MessageVerifier strangers = new MessageVerifier(stranger.publicKey(), prefix, "REPLY", 2000, 0);
        check("vector: another key", strangers.verify(e, at) == null ? strangers.reason() : "accepted",
              "signed REPLY refused: key " + v.get("public_key_hex").substring(0, 16) + " is not the coordinator's (" + MessageVerifier.hex(stranger.keyId()) + ")");
    }

    static reply_t reply(String clientId, long requestId, byte status, String reason) {
        reply_t r = new reply_t();
        r.utime = System.currentTimeMillis() * 1000;
        r.client_id = clientId;
        r.request_id = requestId;
        r.status = status;
        r.reason = reason;
        r.axes = new String[0];
        r.targets = new double[0];
        r.positions = new double[0];
        r.start_utime = new long[0];
        r.param = new param_t();
        r.param.mnemonic = "";
        return r;
    }

    static String statuses(List<reply_t> replies) {
        List<String> names = new ArrayList<>();
        for (reply_t r : replies) names.add(MotionClient.statusName(r.status) + (r.error_code != 0 ? " " + r.error_code : ""));
        return String.join(",", names);
    }

    static void client(Signing.Key coordinator, Path dir) throws Exception {
        long pid = ProcessHandle.current().pid();
        String url = "udpm://239.255.76.67:" + (20000 + (pid * 7 + 3) % 40000) + "?ttl=0";  // this test's own port
        Path pubFile = dir.resolve("coordinator.pub");
        Files.writeString(pubFile, "# the coordinator's key\n" + java.util.Base64.getEncoder().encodeToString(coordinator.publicKey()) + " coordinator admin\n");
        Signing.Key stranger = Signing.fromSeed(new byte[32], "coordinator");
        String prefix = "MOTION_";
        try (MotionClient c = new MotionClient(url, prefix, "java-test")) {
            LCM wire = new LCM(url);
            c.verifyWith(Signing.loadPublicKey(pubFile.toString()), 2000);
            LinkedBlockingQueue<reply_t> seen = new LinkedBlockingQueue<>();
            long rid = c.send(MotionClient.make(request_t.MOVE_ABSOLUTE, new String[] {"x"}, new double[] {1.0}), seen::add);
            long now = System.currentTimeMillis() * 1000;
            wire.publish(prefix + "REPLY", reply(c.id(), rid, reply_t.FAILED, "plain lie"));
            wire.publish(prefix + "SREPLY", sign(stranger, prefix, "REPLY", reply(c.id(), rid, reply_t.FAILED, "another key"), now, now));
            signed_message_t altered = sign(coordinator, prefix, "REPLY", reply(c.id(), rid, reply_t.FAILED, "altered"), now, now + 1);
            altered.signature[7] ^= 0x20;
            wire.publish(prefix + "SREPLY", altered);
            signed_message_t progress = sign(coordinator, prefix, "REPLY", reply(c.id(), rid, reply_t.PROGRESS, ""), now, now + 2);
            wire.publish(prefix + "SREPLY", progress);
            wire.publish(prefix + "SREPLY", progress);  // replayed
            // A SECURITY event naming the request, plain (not the coordinator's signed one): ignored.
            event_t lie = new event_t();
            lie.utime = now;
            lie.kind = event_t.SECURITY;
            lie.source = "coordinator";
            lie.axis = "";
            lie.bus = "";
            lie.text = "signed request refused: bad signature: request " + rid + " of client '" + c.id() + "'";
            wire.publish(prefix + "EVENT", lie);
            wire.publish(prefix + "SREPLY", sign(coordinator, prefix, "REPLY", reply(c.id(), rid, reply_t.DONE, "moved"), now, now + 3));
            List<reply_t> got = new ArrayList<>();
            // In order on one socket: once DONE is here, everything published before it was handled.
            while (got.isEmpty() || !MotionClient.isTerminal(got.get(got.size() - 1).status)) {
                reply_t r = seen.poll(20, TimeUnit.SECONDS);
                if (r == null) break;
                got.add(r);
            }
            check("client: only the coordinator's signed replies end the request", statuses(got), "progress,done");
            check("client: the terminal reply is the coordinator's", got.isEmpty() ? "" : got.get(got.size() - 1).reason, "moved");
            check("client: forged signed replies counted (another key, altered, replayed)", c.forgedReplies(), 3);
            wire.close();
        }
    }

    public static void main(String[] argv) throws Exception {
        Map<String, String> v = new HashMap<>();
        for (String line : Files.readAllLines(Path.of(argv[0]), StandardCharsets.UTF_8)) {
            int eq = line.indexOf(" = ");
            if (!line.startsWith("#") && eq > 0) v.put(line.substring(0, eq), line.substring(eq + 3));
        }
        Path dir = Files.createTempDirectory("motion-java-replies");
        try {
            Path keyFile = dir.resolve("vector.key");
            Files.writeString(keyFile, v.get("key_file_line") + "\n");
            Files.setPosixFilePermissions(keyFile, java.nio.file.attribute.PosixFilePermissions.fromString("rw-------"));
            Signing.Key coordinator = Signing.loadPrivateKey(keyFile.toString());
            vector(v, coordinator);
            client(coordinator, dir);
        } finally {
            try (var files = Files.list(dir)) {
                for (Path p : (Iterable<Path>) files::iterator) Files.delete(p);
            }
            Files.delete(dir);
        }
        System.out.println(failures == 0 ? "reply verification ok" : failures + " checks FAILED");
        System.exit(failures == 0 ? 0 : 1);
    }
}
