// Gateway-signed axis states in the Java client (ctest clients_java_state_verification):
//  1. the gateway's signed state of tests/vectors/signed_state_v1.txt (the bytes the C++
//     MessageSigner produces) verifies here, byte for byte, from a key for every bus and from a key
//     bound to buses including the state's, and is refused from a key bound to another bus,
//     replayed, altered, stale or under a key that is not a gateway key; GatewayKeys reads only the
//     gateway keys of an authorized_keys file, with their buses, and names every bad line;
//  2. a MotionClient after verifyStatesWith(keys), on its own LCM URL: a plain forged state, one
//     signed with a stranger's key, a tampered one, a replayed one and one from a key bound to
//     another bus are not taken (forgedStates() counts the signed ones); the gateways' signed
//     states are; without verifyStatesWith the plain state is taken and statesVerified() is false.
// Prints one line per check; "FAIL ..." for each that failed, "state verification ok" when all passed.
//   java -cp lcm.jar:motionlcm.jar:classes StateVerification tests/vectors/signed_state_v1.txt
import java.nio.charset.StandardCharsets;
import java.nio.file.Files;
import java.nio.file.Path;
import java.util.ArrayList;
import java.util.Base64;
import java.util.HashMap;
import java.util.List;
import java.util.Map;
import java.util.concurrent.LinkedBlockingQueue;
import java.util.concurrent.TimeUnit;

import lcm.lcm.LCM;
import motionlcm.axis_state_t;
import motionlcm.signed_message_t;

public class StateVerification {
    static final String OPERATOR_LINE = "A6EHv/POEL4dcN0Y50vAmWfk1jCbpQ1fHdyGZBJVMbg= alice operate";

    static void check(String what, Object actual, Object expected) { ReplyVerification.check(what, actual, expected); }

    static String refused(Object message, MessageVerifier v) { return message == null ? v.reason() : "accepted"; }

    static MessageVerifier verifier(List<GatewayKeys.Key> keys, String prefix, long notBeforeUs) throws Exception {
        return new MessageVerifier(keys, "a gateway key", prefix, "AXIS_STATE", 2000, notBeforeUs);
    }

    static List<GatewayKeys.Key> keys(String... lines) throws Signing.KeyFileException {
        return GatewayKeys.parse("# the lab's principals\n" + OPERATOR_LINE + "\n" + String.join("\n", lines) + "\n", "authorized_keys");
    }

    static axis_state_t verifyState(MessageVerifier v, signed_message_t e, long at) {
        return v.verifyMessage(e, at, axis_state_t::new, m -> m.bus);
    }

    static void vector(Map<String, String> v, Signing.Key gateway) throws Exception {
        String prefix = v.get("prefix");
        long at = Long.parseLong(v.get("utime"));
        signed_message_t e = new signed_message_t(ReplyVerification.unhex(v.get("envelope_hex")));
        check("vector: public key of the key file", MessageVerifier.hex(gateway.publicKey()), v.get("public_key_hex"));
        check("vector: Java signs the C++ gateway's bytes",
              MessageVerifier.hex(ReplyVerification.sign(gateway, prefix, "AXIS_STATE", new axis_state_t(e.message), at, e.counter).signature),
              v.get("signature_hex"));
        for (String line : new String[] {"authorized_every_bus", "authorized_bound"}) {
            MessageVerifier verifier = verifier(keys(v.get(line)), prefix, at - 1000);
            axis_state_t s = verifyState(verifier, e, at + 500);
            check("vector: C++'s signed state verifies (" + line + ")", s == null ? verifier.reason() : s.axis + " " + s.bus + " " + s.position, "x can0 10.5");
            check("vector: the state's bytes (" + line + ")", s == null ? "" : MessageVerifier.hex(ReplyVerification.encode(s)), v.get("message_hex"));
            check("vector: replayed (" + line + ")", refused(verifyState(verifier, e, at + 600), verifier), v.get("refused_replayed"));
        }
        MessageVerifier otherBus = verifier(keys(v.get("authorized_other_bus")), prefix, at - 1000);
        check("vector: a key bound to another bus", refused(verifyState(otherBus, e, at + 500), otherBus), v.get("refused_other_bus"));
        List<GatewayKeys.Key> everyBus = keys(v.get("authorized_every_bus"));
        signed_message_t altered = new signed_message_t(ReplyVerification.unhex(v.get("envelope_hex")));
        altered.message[altered.message.length - 20] ^= 1;
        MessageVerifier fresh = verifier(everyBus, prefix, 0);
        check("vector: altered", refused(verifyState(fresh, altered, at), fresh), "signed AXIS_STATE refused: bad signature (forged or altered in transit)");
        MessageVerifier late = verifier(everyBus, prefix, 0);
        check("vector: stale", refused(verifyState(late, e, at + 2_500_000), late),
              "signed AXIS_STATE refused: stale timestamp: signed 2500 ms ago, outside the window of 2000 ms (clocks out of sync, or a replay)");
        Signing.Key stranger = Signing.fromSeed(new byte[32], "stranger");
        MessageVerifier strangers = verifier(List.of(new GatewayKeys.Key(stranger.publicKey(), "stranger", null)), prefix, 0);
        check("vector: not a gateway key", refused(verifyState(strangers, e, at), strangers),
              "signed AXIS_STATE refused: key " + v.get("public_key_hex").substring(0, 16) + " is not a gateway key");

        List<GatewayKeys.Key> two = keys(v.get("authorized_bound"), "O2onvM62pC1io6jQKm8Nc2UyFXcd4kOmOsBIoYtZ2ik= gw2 gateway");
        check("keys: only the gateway keys, with their buses", two.get(0).name + " " + two.get(0).buses + " " + two.get(1).name + " " + two.get(1).buses,
              "vector [rs485a, can0] gw2 null");
        String errors;
        try {
            keys(v.get("authorized_every_bus") + " extra more", OPERATOR_LINE.replace("alice", "bob") + " buses=can0",
                 v.get("authorized_other_bus").replace("rs485a", "").replace("vector", "v2"),
                 "O2onvM62pC1io6jQKm8Nc2UyFXcd4kOmOsBIoYtZ2ik= gw2 gateway busses=can0");
            errors = "accepted";
        } catch (Signing.KeyFileException ex) {
            errors = ex.getMessage();
        }
        check("keys: every bad line named", errors,
              "authorized_keys:3: expected '<base64 public key> <name> <role> [buses=<bus>,...]', got 5 fields\n"
              + "authorized_keys:4: buses= binds a key of role gateway to buses; 'bob' has role operate\n"
              + "authorized_keys:5: expected 'buses=<bus>[,<bus>...]' after the role, got 'buses='\n"
              + "authorized_keys:6: expected 'buses=<bus>[,<bus>...]' after the role, got 'busses=can0'");
    }

    static axis_state_t state(double position, boolean fault, String bus) {
        axis_state_t s = new axis_state_t();
        s.utime = s.sample_utime = System.currentTimeMillis() * 1000;
        s.axis = "x";
        s.family = "uim342";
        s.bus = bus;
        s.fault_text = "";
        s.position = position;
        s.fault = fault;
        return s;
    }

    static long now() { return System.currentTimeMillis() * 1000; }

    static String seen(List<axis_state_t> states) {
        List<String> out = new ArrayList<>();
        for (axis_state_t s : states) out.add(s.bus + ":" + s.position);
        return String.join(",", out);
    }

    static void client(Path dir) throws Exception {
        long pid = ProcessHandle.current().pid();
        String url = "udpm://239.255.76.67:" + (20000 + (pid * 7 + 4) % 40000) + "?ttl=0";  // this test's own port
        String prefix = "MOTION_";
        Signing.Key can0 = Signing.fromSeed(filled(4), "gateway-can0");
        Signing.Key rs485 = Signing.fromSeed(filled(5), "gateway-rs485a");
        Path file = dir.resolve("authorized_keys");
        Files.writeString(file, Base64.getEncoder().encodeToString(can0.publicKey()) + " gateway-can0 gateway buses=can0\n"
                                + Base64.getEncoder().encodeToString(rs485.publicKey()) + " gateway-rs485a gateway buses=rs485a\n");
        LinkedBlockingQueue<axis_state_t> states = new LinkedBlockingQueue<>();
        try (MotionClient c = new MotionClient(url, prefix, "java-test")) {
            LCM wire = new LCM(url);
            c.onAxisState(states::add);
            wire.publish(prefix + "AXIS_STATE", state(1.0, false, "can0"));
            axis_state_t plain = states.poll(20, TimeUnit.SECONDS);
            check("client: unverifying, the plain state is taken", plain == null ? "none" : plain.position + " " + c.statesVerified(), "1.0 false");

            c.verifyStatesWith(GatewayKeys.load(file.toString()), 2000);
            check("client: verifying forgets the unverified states", c.axisStates().size() + " " + c.statesVerified(), "0 true");
            signed_message_t genuine = ReplyVerification.sign(can0, prefix, "AXIS_STATE", state(2.0, false, "can0"), now(), now());
            wire.publish(prefix + "SAXIS_STATE", genuine);
            axis_state_t lie = state(99.0, true, "can0");
            wire.publish(prefix + "AXIS_STATE", lie);  // plain forged: ignored, like every plain copy
            wire.publish(prefix + "SAXIS_STATE", ReplyVerification.sign(Signing.fromSeed(filled(9), "gateway-can0"), prefix, "AXIS_STATE", lie, now(), now()));
            signed_message_t tampered = ReplyVerification.sign(can0, prefix, "AXIS_STATE", lie, now(), genuine.counter + 1);
            tampered.signature[7] ^= 0x20;
            wire.publish(prefix + "SAXIS_STATE", tampered);
            wire.publish(prefix + "SAXIS_STATE", genuine);  // replayed
            wire.publish(prefix + "SAXIS_STATE", ReplyVerification.sign(rs485, prefix, "AXIS_STATE", lie, now(), now()));  // rs485a's key, bus can0
            wire.publish(prefix + "SAXIS_STATE", ReplyVerification.sign(rs485, prefix, "AXIS_STATE", state(3.0, false, "rs485a"), now(), now()));
            wire.publish(prefix + "SAXIS_STATE", ReplyVerification.sign(can0, prefix, "AXIS_STATE", state(4.0, false, "can0"), now(), genuine.counter + 2));
            List<axis_state_t> got = new ArrayList<>();
            // In order on one socket: once the last genuine state is here, everything before it was handled.
            while (got.isEmpty() || got.get(got.size() - 1).position != 4.0) {
                axis_state_t s = states.poll(20, TimeUnit.SECONDS);
                if (s == null) break;
                got.add(s);
            }
            check("client: only the gateways' signed states for their buses are taken", seen(got), "can0:2.0,rs485a:3.0,can0:4.0");
            check("client: forged signed states counted (stranger, tampered, replayed, another bus's key)", c.forgedStates(), 4);
            axis_state_t x = c.axisStates().get("x");
            check("client: the axis's state is the gateway's", x == null ? "none" : x.bus + ":" + x.position, "can0:4.0");
            wire.close();
        }
    }

    static byte[] filled(int value) {
        byte[] b = new byte[32];
        java.util.Arrays.fill(b, (byte) value);
        return b;
    }

    public static void main(String[] argv) throws Exception {
        Map<String, String> v = new HashMap<>();
        for (String line : Files.readAllLines(Path.of(argv[0]), StandardCharsets.UTF_8)) {
            int eq = line.indexOf(" = ");
            if (!line.startsWith("#") && eq > 0) v.put(line.substring(0, eq), line.substring(eq + 3));
        }
        Path dir = Files.createTempDirectory("motion-java-states");
        try {
            Path keyFile = dir.resolve("vector.key");
            Files.writeString(keyFile, v.get("key_file_line") + "\n");
            Files.setPosixFilePermissions(keyFile, java.nio.file.attribute.PosixFilePermissions.fromString("rw-------"));
            vector(v, Signing.loadPrivateKey(keyFile.toString()));
            client(dir);
        } finally {
            try (var files = Files.list(dir)) {
                for (Path p : (Iterable<Path>) files::iterator) Files.delete(p);
            }
            Files.delete(dir);
        }
        int failures = ReplyVerification.failures;
        System.out.println(failures == 0 ? "state verification ok" : failures + " checks FAILED");
        System.exit(failures == 0 ? 0 : 1);
    }
}
