"""Test certificates made with openssl."""
import os
import subprocess


def _openssl(folder, *args):
    subprocess.run(["openssl", *args], check=True, capture_output=True, cwd=folder)


def make_ca(folder, name):
    """NAME.pem and NAME.key in `folder`: a self-signed CA."""
    _openssl(folder, "req", "-x509", "-newkey", "rsa:2048", "-nodes", "-days", "2", "-subj",
             f"/CN=modtap test {name}", "-keyout", f"{name}.key", "-out", f"{name}.pem")


def make_certificate(folder, name, ca, dns_name=None):
    """NAME.pem and NAME.key signed by the CA `ca`; for a server, carrying `dns_name`."""
    _openssl(folder, "req", "-newkey", "rsa:2048", "-nodes", "-subj",
             f"/CN={dns_name or name}", "-keyout", f"{name}.key", "-out", f"{name}.csr")
    extension = []
    if dns_name:
        with open(os.path.join(folder, f"{name}.ext"), "w") as f:
            f.write(f"subjectAltName=DNS:{dns_name}\n")
        extension = ["-extfile", f"{name}.ext"]
    _openssl(folder, "x509", "-req", "-in", f"{name}.csr", "-CA", f"{ca}.pem", "-CAkey",
             f"{ca}.key", "-CAcreateserial", "-days", "2", *extension, "-out", f"{name}.pem")

