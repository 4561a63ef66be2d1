// Lost datagrams in the Java client (ctest clients_java_lost_datagrams): request() sends a request
// again while nothing is heard of it (RESEND_AFTER_MS before its first reply, QUIET_RESEND_MS after),
// as the C++ and Python clients do. A scripted coordinator on this test's own LCM URL (an LCM of its
// own, answering on its receive thread) answers each copy of a request it hears with a list of
// replies; an empty list is a copy, or its replies, lost.
//  1. the first request lost: DONE all the same, after exactly 2 sends, equal but for utime;
//  2. the first terminal reply lost: sent again once after the ACCEPTED, DONE;
//  3. silence: FAILED "no reply from the coordinator within 2000 ms" after 4 sends (0, 0.5, 1, 1.5 s);
//  4. the terminal reply heard twice, and an ACCEPTED after it (answers to copies sent again): the
//     handler of send() and follow() gets accepted,done, the terminal reply once;
//  5. signed, the request lost: the copy sent again has a new utime, counter and signature (which
//     verifies), its payload the request's but for utime.
// The checks and replies are ReplyVerification's. Prints one line per check; "FAIL ..." for each
// that failed, "lost datagrams ok" when all passed.
//   java -cp lcm.jar:motionlcm.jar:classes LostDatagrams
import java.security.Signature;
import java.util.ArrayList;
import java.util.Arrays;
import java.util.Collections;
import java.util.List;
import java.util.concurrent.CompletableFuture;

import lcm.lcm.LCM;
import lcm.lcm.LCMDataInputStream;
import lcm.lcm.LCMSubscriber;
import motionlcm.reply_t;
import motionlcm.request_t;
import motionlcm.signed_request_t;

public class LostDatagrams {
    static final byte ACCEPTED = reply_t.ACCEPTED;
    static final byte DONE = reply_t.DONE;
    static String url;

    /** A client and its scripted coordinator; each case its own channel prefix. With a key the
     *  client signs and the coordinator hears SREQUEST: copies holds the payloads, envelopes the rest. */
    static final class Lossy implements AutoCloseable {
        final MotionClient client;
        final LCM coordinator;
        final List<request_t> copies = Collections.synchronizedList(new ArrayList<>());
        final List<signed_request_t> envelopes = Collections.synchronizedList(new ArrayList<>());

        Lossy(String which, Signing.Key key, byte[]... script) throws Exception {
            String prefix = which + "_";
            client = new MotionClient(url, prefix, "java-test");
            if (key != null) client.signWith(key);
            List<byte[]> answers = Collections.synchronizedList(new ArrayList<>(Arrays.asList(script)));
            coordinator = new LCM(url);
            coordinator.subscribe(prefix + (key != null ? "SREQUEST" : "REQUEST"), new LCMSubscriber() {
                public void messageReceived(LCM l, String ch, LCMDataInputStream ins) {
                    try {
                        request_t r;
                        if (key != null) {
                            signed_request_t e = new signed_request_t(ins);
                            envelopes.add(e);
                            r = new request_t(e.payload);
                        } else {
                            r = new request_t(ins);
                        }
                        copies.add(r);
                        for (byte status : answers.isEmpty() ? new byte[0] : answers.remove(0)) {
                            l.publish(prefix + "REPLY", ReplyVerification.reply(r.client_id, r.request_id, status, "scripted"));
                        }
                    } catch (java.io.IOException e) {
                        check("the coordinator decodes each request", e, "decoded");
                    }
                }
            });
        }

        @Override
        public void close() {
            coordinator.close();
            client.close();
        }
    }

    static byte[] statuses(byte... s) { return s; }

    static String status(reply_t r) { return MotionClient.statusName(r.status) + (r.error_code != 0 ? " " + r.error_code : ""); }

    /** "equal" when the copies heard differ in utime only. */
    static String sameButUtime(List<request_t> copies) {
        byte[] first = null;
        synchronized (copies) {
            for (int i = 0; i < copies.size(); i++) {
                copies.get(i).utime = 0;
                byte[] bytes = Signing.encode(copies.get(i));
                if (first == null) first = bytes;
                if (!Arrays.equals(bytes, first)) return "copy " + (i + 1) + " differs";
            }
        }
        return first != null ? "equal" : "none";
    }

    static void check(String what, Object actual, Object expected) { ReplyVerification.check(what, actual, expected); }

    public static void main(String[] argv) throws Exception {
        url = "udpm://239.255.76.67:" + (20000 + (ProcessHandle.current().pid() * 7 + 1) % 40000) + "?ttl=0";  // own port

        try (Lossy t = new Lossy("LOST_REQUEST", null, statuses(), statuses(ACCEPTED, DONE))) {
            reply_t r = t.client.request(request_t.MOVE_ABSOLUTE, new String[] {"x", "y"}, new double[] {1.5, -2}, 5000);
            check("request lost: the terminal reply all the same", status(r), "done");
            check("request lost: sends heard", t.copies.size(), 2);
            check("request lost: the copy sent again is the request, but for its utime", sameButUtime(t.copies), "equal");
            check("request lost: sent again", t.client.resent(), 1);
        }

        try (Lossy t = new Lossy("LOST_DONE", null, statuses(ACCEPTED), statuses(DONE))) {
            List<String> progress = Collections.synchronizedList(new ArrayList<>());
            reply_t r = t.client.request(MotionClient.make(request_t.ENABLE, new String[] {"x"}, null), 5000, p -> progress.add(status(p)));
            check("terminal reply lost: asked for again, the terminal reply", status(r), "done");
            check("terminal reply lost: sends heard", t.copies.size(), 2);
            check("terminal reply lost: the copy sent again is the request, but for its utime", sameButUtime(t.copies), "equal");
            check("terminal reply lost: progress replies", String.join(",", progress), "accepted");
        }

        try (Lossy t = new Lossy("SILENCE", null)) {
            reply_t r = t.client.request(request_t.ENABLE, new String[] {"x"}, null, 5000);
            check("silence: a local failed reply (timeout)", status(r), "failed 13");
            check("silence: it says nothing was heard", r.reason.startsWith("no reply from the coordinator within 2000 ms: is motion-coordinator running on "), true);
            check("silence: sends, at 0, 0.5, 1 and 1.5 s", t.copies.size(), 4);
            check("silence: the copies are the request, but for their utime", sameButUtime(t.copies), "equal");
        }

        try (Lossy t = new Lossy("TWICE", null, statuses(ACCEPTED), statuses(DONE, DONE, ACCEPTED))) {
            List<String> seen = Collections.synchronizedList(new ArrayList<>());
            CompletableFuture<reply_t> terminal = new CompletableFuture<>();
            long id = t.client.send(MotionClient.make(request_t.ENABLE, new String[] {"x"}, null), x -> {
                seen.add(status(x));
                if (MotionClient.isTerminal(x.status)) terminal.complete(x);
            });
            boolean ended = t.client.follow(id, terminal, 5000);
            Thread.sleep(300);  // the repeats arrive meanwhile
            check("repeated terminal reply: the request ended", ended, true);
            check("repeated terminal reply: passed on once", String.join(",", seen), "accepted,done");
            check("repeated terminal reply: sends heard", t.copies.size(), 2);
        }

        Signing.Key key = Signing.fromSeed(new byte[] {7, 7, 7, 7, 7, 7, 7, 7, 7, 7, 7, 7, 7, 7, 7, 7, 7, 7, 7, 7, 7, 7, 7, 7, 7, 7, 7, 7, 7, 7, 7, 7}, "lost");
        try (Lossy t = new Lossy("SIGNED", key, statuses(), statuses(ACCEPTED, DONE))) {
            reply_t r = t.client.request(request_t.ENABLE, new String[] {"x"}, null, 5000);
            check("signed, request lost: the terminal reply", status(r), "done");
            check("signed, request lost: sends heard", t.envelopes.size(), 2);
            signed_request_t first = t.envelopes.get(0);
            signed_request_t again = t.envelopes.get(t.envelopes.size() - 1);
            check("signed, request lost: a new utime and counter", again.utime > first.utime && again.counter > first.counter, true);
            check("signed, request lost: the envelope's utime is the payload's", t.copies.get(t.copies.size() - 1).utime, again.utime);
            Signature verifier = Signature.getInstance("Ed25519");
            verifier.initVerify(Signing.publicKey(key.publicKey()));
            verifier.update(Signing.signedBytes(t.client.channel(""), key.keyId(), again.counter, again.utime, again.payload));
            check("signed, request lost: signed anew, and the signature verifies",
                  !Arrays.equals(again.signature, first.signature) && verifier.verify(again.signature), true);
            check("signed, request lost: the payloads are the request, but for their utime", sameButUtime(t.copies), "equal");
        }

        System.out.println(ReplyVerification.failures == 0 ? "lost datagrams ok" : ReplyVerification.failures + " checks FAILED");
        System.exit(ReplyVerification.failures == 0 ? 0 : 1);
    }
}
