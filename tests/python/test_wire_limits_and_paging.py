"""The wire contract's sizes and paging as an outside Python client meets them (session 12):
ListNormalMaps pages (AIP-158) through the raw stub, Client.list_normal_maps and
`glint normal-maps list`; the Sample reply's bytes per sample the clients size calls by; and a
client whose message limit equals the server's receiving the server's largest reply."""

from __future__ import annotations

import subprocess

import grpc
import pytest

import glint
from conftest import running_glintd

GGX = {"model": "SMOOTH", "ndf": "GGX", "alpha_x": 0.3, "alpha_y": 0.15, "schlick": {"f0": [0.9, 0.6, 0.3]}}


def test_normal_maps_are_listed_in_pages_by_every_client(cli, tmp_path):
    """Seven maps, pages of 3: the raw stub gets 3, 3 and 1 maps with tokens between them, in
    digest order, each map once; Client.list_normal_maps and the CLI follow the pages to the same
    list. Before paging the server ignored page_size and sent every map in one reply, which grew
    with the map count past the message limit."""
    with running_glintd("--device", "host", "--warm", "none") as (address, _):
        with glint.Client(address) as client:
            digests = set()
            for seed in range(1, 8):
                path = tmp_path / f"bumpy{seed}.exr"
                made = subprocess.run([cli.binary, "normal-map", "bumpy", "--size", "8", "--seed", str(seed),
                                       "--out", str(path)], capture_output=True, text=True)
                assert made.returncode == 0, made.stderr
                digests.add(client.upload_normal_map(path))
            assert len(digests) == 7
            expected = sorted(digests)

            pages, token = [], ""
            while True:
                page = client._stub.ListNormalMaps(glint.pb.ListNormalMapsRequest(page_size=3, page_token=token))
                pages.append([m.digest for m in page.maps])
                if not page.next_page_token:
                    break
                token = page.next_page_token
                assert len(pages) < 10, "paging does not end"
            assert [len(p) for p in pages] == [3, 3, 1]
            assert [d for p in pages for d in p] == expected

            assert [m.digest for m in client.list_normal_maps(page_size=2)] == expected
            assert [m.digest for m in client.list_normal_maps()] == expected

            for request, field in ((glint.pb.ListNormalMapsRequest(page_size=-1), "page_size"),
                                   (glint.pb.ListNormalMapsRequest(page_token="sha256:" + "0" * 64), "page_token")):
                with pytest.raises(grpc.RpcError) as refused:
                    client._stub.ListNormalMaps(request)
                assert refused.value.code() == grpc.StatusCode.INVALID_ARGUMENT
                assert field in refused.value.details()

            listed = subprocess.run([cli.binary, "normal-maps", "list", "--server", address, "--page-size", "3"],
                                    capture_output=True, text=True)
            assert listed.returncode == 0, listed.stderr
            lines = listed.stdout.splitlines()
            assert [line.split("\t")[0] for line in lines] == expected
            assert all(line.split("\t")[1] == "8x8" for line in lines)
            assert all(line.split("\t")[3].startswith("bumpy") for line in lines)

            gone = expected[0]
            deleted = subprocess.run([cli.binary, "normal-maps", "delete", "--server", address, gone],
                                     capture_output=True, text=True)
            assert deleted.returncode == 0, deleted.stderr
            assert [m.digest for m in client.list_normal_maps(page_size=3)] == expected[1:]


def test_sample_replies_take_the_documented_bytes_per_sample(client):
    """glint.SAMPLE_REPLY_BYTES_PER_SAMPLE (what Client.sample sizes its calls by) against real
    replies: n samples take between 28 n and 28 n + 1024 bytes (the proto's bound on the rest)."""
    assert glint.SAMPLE_REPLY_BYTES_PER_SAMPLE == 28
    material = glint.pb.Material(model=glint.pb.SMOOTH, ndf=glint.pb.GGX, alpha_x=0.3, alpha_y=0.15,
                                 schlick=glint.pb.SchlickFresnel(f0=[0.9, 0.6, 0.3]))
    for k in (1, 100, 4096, 16384):
        for n in (1, 2):
            request = glint.pb.SampleRequest(material=material, samples_per_query=k, seed=3,
                                             queries=glint.pb.QueryBatch(count=n, wo=[0.0, 0.6, 0.8] * n))
            reply = client._stub.Sample(request)
            samples = n * k
            assert len(reply.pdf) == samples
            size = reply.ByteSize()
            assert glint.SAMPLE_REPLY_BYTES_PER_SAMPLE * samples <= size, (k, n, size)
            assert size <= glint.SAMPLE_REPLY_BYTES_PER_SAMPLE * samples + 1024, (k, n, size)


def test_a_client_at_the_servers_limit_receives_its_largest_reply():
    """A reply may be up to 4096 bytes over the server's --max-message-mb (the stats; a stream
    result's indices), so Client(max_message_bytes=the server's) receives that much more. Before,
    its receive limit was the server's: a stream chunk just within 1 MiB got a result of
    1 MiB + ~20 bytes, refused by the client with RESOURCE_EXHAUSTED."""
    limit = 1 << 20
    with running_glintd("--device", "host", "--warm", "none", "--max-message-mb", "1") as (address, _):
        with glint.Client(address, max_message_bytes=limit) as small:
            first = glint.pb.EvaluateChunk(chunk_index=0, request=glint.pb.EvaluateRequest(
                material=glint.pb.Material(model=glint.pb.SMOOTH, ndf=glint.pb.GGX, alpha_x=0.3, alpha_y=0.3,
                                           schlick=glint.pb.SchlickFresnel(f0=[0.5, 0.5, 0.5])),
                lights=[glint.pb.Light(point=glint.pb.PointLight(position=[0, 0, 3], intensity=[1, 1, 1]))],
                queries=glint.pb.QueryBatch(count=1, wo=[0.0, 0.6, 0.8])))
            n = limit // 12
            while True:
                second = glint.pb.EvaluateChunk(chunk_index=1, request=glint.pb.EvaluateRequest(
                    queries=glint.pb.QueryBatch(count=n, wo=[0.0, 0.6, 0.8] * n)))
                if second.ByteSize() <= limit:
                    break
                n -= 1
            results = list(small._stub.EvaluateStream(iter([first, second])))
            assert [r.result.count for r in results] == [1, n]
            assert limit < results[1].ByteSize() <= limit + glint.REPLY_OVERHEAD_BYTES
