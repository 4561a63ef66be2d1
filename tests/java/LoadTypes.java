// Loads every generated motionlcm class from the types jar with Debian's lcm.jar, as lcm-spy and
// Java clients do, checks the static LCM_FINGERPRINT that lcm-spy's type scanner looks for, and
// round-trips an instance through LCM's encoder. Usage: java -cp lcm.jar:motionlcm.jar:. LoadTypes NAME...
import java.io.ByteArrayOutputStream;
import java.io.DataOutputStream;
import java.lang.reflect.Field;
import lcm.lcm.LCMDataInputStream;
import lcm.lcm.LCMEncodable;

public class LoadTypes {
    // Null strings and nested structs are not encodable: fill what the constructor left null.
    static void fill(Object msg) throws Exception {
        for (Field f : msg.getClass().getFields()) {
            if (java.lang.reflect.Modifier.isStatic(f.getModifiers())) continue;
            if (f.getType() == String.class) {
                f.set(msg, "x");
            } else if (LCMEncodable.class.isAssignableFrom(f.getType())) {
                Object nested = f.getType().getConstructor().newInstance();
                fill(nested);
                f.set(msg, nested);
            }
        }
    }

    public static void main(String[] args) throws Exception {
        int failures = 0;
        for (String name : args) {
            try {
                Class<?> cls = Class.forName("motionlcm." + name);
                Field fp = cls.getField("LCM_FINGERPRINT");
                long fingerprint = fp.getLong(null);
                LCMEncodable msg = (LCMEncodable) cls.getConstructor().newInstance();
                fill(msg);
                ByteArrayOutputStream bytes = new ByteArrayOutputStream();
                msg.encode(new DataOutputStream(bytes));
                Object back = cls.getConstructor(byte[].class).newInstance((Object) bytes.toByteArray());
                System.out.printf("ok %s fingerprint=%016x bytes=%d%n", name, fingerprint, bytes.size());
                if (back == null) failures++;
            } catch (Throwable e) {
                Throwable cause = e.getCause() != null ? e.getCause() : e;
                System.out.println("FAIL " + name + ": " + cause);
                failures++;
            }
        }
        System.out.println(failures == 0 ? "all types load" : failures + " types failed");
        System.exit(failures == 0 ? 0 : 1);
    }
}
