# nginx from Debian's package as the gRPC load balancer of docker/compose.yaml.
FROM debian:bookworm-slim
RUN apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
      nginx-light \
    && rm -rf /var/lib/apt/lists/*
COPY docker/nginx/glint-lb.conf /etc/nginx/nginx.conf
EXPOSE 50051
CMD ["nginx", "-g", "daemon off;"]
